"""Render jobs for the executor tests: real Mitsuba renders of a small scene, with a twist.

They live in a module of their own (not the test file) so worker processes import them by name.
"""
from dataclasses import dataclass, field, replace

from lab.paths import SCENES
from lab.reference.passes import RenderJob, RenderPass, pass_seeds
from lab.scene import load_scene


def small_scene(width: int = 24, height: int = 24):
    """scenes/tiny.toml at ``width`` x ``height`` pixels."""
    tiny = load_scene(SCENES / "tiny.toml")
    return replace(tiny, info=replace(tiny.info, resolution=(width, height)))


class PassFailed(RuntimeError):
    """What :class:`FlakyJob` raises (an interruption at a known pass)."""


@dataclass
class FlakyJob(RenderJob):
    """The reference job, whose render of pass ``fail_at`` raises; records the passes it rendered
    in this process."""

    fail_at: int = -1
    rendered: list = field(default_factory=list, compare=False)

    def render(self, p: RenderPass):
        if p.index == self.fail_at:
            raise PassFailed(f"pass {p.index} interrupted")
        self.rendered.append(p.index)
        return super().render(p)


@dataclass
class ChannelJob(RenderJob):
    """Passes that weigh the channels differently (as a per-wavelength thick-lens job does): red,
    green and blue alone with 4 spp each, then one 2-spp pass for all three. Each renders the
    plain scene with its own seed."""

    def passes(self) -> list[RenderPass]:
        weights = [(4.0, 0.0, 0.0), (0.0, 4.0, 0.0), (0.0, 0.0, 4.0), (2.0, 2.0, 2.0)]
        seeds = pass_seeds(self.scene.render.seed, self.stream, len(weights))
        return [RenderPass(i, int(max(w)), s, w, (("channel", "rgb"[i] if i < 3 else "all"),))
                for i, (w, s) in enumerate(zip(weights, seeds))]
