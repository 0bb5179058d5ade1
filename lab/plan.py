"""Which effects a scene calls for, and so what to precompute, render and run (``splatlab plan``).

Each camera model (:mod:`lab.cameras`) has a plan rule, :meth:`lab.cameras.Camera.plan`, that
fills in its part of the plan: depth of field, aperture, PSF models, references, runtime passes.
Effects a scene does not call for are listed as skipped with the reason, so a plan always says
what it will *not* do.

The camera modules import :class:`Step` from here, so this module does not import the scene
module (which imports them).
"""
from __future__ import annotations

from dataclasses import dataclass, field

from .errors import UserError
from .motion import describe_motion, scene_moves


NO_REFERENCE = "none"   # the reference step of a plan nothing physical can be scored against


@dataclass(frozen=True)
class Step:
    """One thing to produce (a reference, an input) or to skip: ``name`` and a one-line ``detail``."""

    name: str
    detail: str


@dataclass(frozen=True)
class Plan:
    """What :func:`make_plan` decided for one scene.

    Attributes
    ----------
    scene : str
        Scene name.
    source : str
        The scene file.
    resolution : (int, int)
        Width, height in pixels.
    effects : dict of str -> str
        ``dof`` ("thin" | "none"), ``motion``, ``medium``, ``chromatic``, ``aperture``.
    psf_models : tuple of str
        PSF models to precompute (names in the PSF model registry), e.g. ``("simple_lens",)``.
    references : tuple of Step
        Ground-truth renders, e.g. ``mitsuba_thinlens``; for a pinhole, ``pinhole`` itself.
    inputs : tuple of Step
        Labelled-pixel inputs for the runtime.
    runtime_passes : tuple of str
        Runtime passes in order by label (the report's method names), e.g. ``("spreadlets",
        "splat", "filter")``, ``("polygon", "polygon_layers", "polygon_layered_input")`` or
        ``("identity",)``.
    skipped : tuple of Step
        What is not done, with the reason.
    pass_runs : dict of str -> (str, dict)
        Label -> (registered runtime pass, its options), e.g. ``"polygon_layers"`` ->
        ``("polygon", {"layers": 8})``; a label the camera's rule does not map is the pass of
        that name without options (:meth:`pass_run`).
    """

    scene: str
    source: str
    resolution: tuple[int, int]
    effects: dict[str, str]
    psf_models: tuple[str, ...]
    references: tuple[Step, ...]
    inputs: tuple[Step, ...]
    runtime_passes: tuple[str, ...]
    skipped: tuple[Step, ...]
    pass_runs: dict = field(default_factory=dict)

    @property
    def scored(self) -> bool:
        """False when the plan has no reference to score the methods against (:data:`NO_REFERENCE`)."""
        return self.references[0].name != NO_REFERENCE

    def pass_run(self, label: str) -> tuple:
        """``(registered runtime pass, options)`` of the runtime pass ``label``."""
        return self.pass_runs.get(label, (label, {}))

    def describe(self) -> str:
        """Human-readable plan, one item per line."""
        w, h = self.resolution
        lines = [f"plan for scene {self.scene!r} ({self.source}), {w}x{h}", "effects:"]
        lines += [f"  {k:<10} {v}" for k, v in self.effects.items()]
        lines.append("PSF models to precompute: " + (", ".join(self.psf_models) or "none"))
        for title, steps in (("references", self.references), ("inputs", self.inputs)):
            lines.append(f"{title}:")
            lines += [f"  {s.name:<18} {s.detail}" for s in steps]
        lines.append("runtime passes: " + " -> ".join(self.runtime_passes))
        lines.append("skipped:" if self.skipped else "skipped: nothing")
        lines += [f"  {s.name}: {s.detail}" for s in self.skipped]
        return "\n".join(lines)


# The PSF models whose spreadlet passes the plan runs in global depth layers (binned in the camera's
# signed CoC, paraxial for a thick lens): the volume models add each pixel's unscattered light on its
# own pixel, which layers do not composite (the pass refuses them).
DEPTH_LAYER_MODELS = ("simple_lens", "combined", "stylized", "physical_lens")
LAYERED_METHODS = ("spreadlets", "splat", "filter")


def _with_depth_layers(rule: dict, scene, skipped: list) -> dict:
    """``[render] depth_layers``: the plan's spreadlet passes again in that many global depth layers
    (LSR18 6.2; labels ``spreadlets_layers``, ...), or a skipped step saying why they cannot be."""
    n = scene.render.depth_layers
    if n is None:
        return rule
    methods = [m for m in LAYERED_METHODS if m in rule["runtime_passes"]]
    why = None
    if not methods:
        why = "this camera's plan has no spreadlet passes (spreadlets, splat, filter)"
    elif not set(rule["psf_models"]) <= set(DEPTH_LAYER_MODELS):
        why = (f"the {', '.join(rule['psf_models'])} database's passes do not draw in layers (they do for "
               f"{', '.join(DEPTH_LAYER_MODELS)})")
    elif rule["dof"] == "none":
        why = "a pinhole has no depth of field: every pixel is in one layer of signed CoC 0"
    if why is not None:
        skipped.append(Step(f"depth_layers = {n}", why))
        return rule
    labels = tuple(f"{m}_layers" for m in methods)
    runs = dict(rule.get("pass_runs", {}), **{label: (m, {"layers": n}) for label, m in zip(labels, methods)})
    return dict(rule, runtime_passes=tuple(rule["runtime_passes"]) + labels, pass_runs=runs)


def make_plan(scene) -> Plan:
    """Decide the effects, PSF models, references, inputs and runtime passes for ``scene``.

    Parameters
    ----------
    scene : lab.scene.Scene
        A validated scene (:func:`lab.scene.load_scene`).

    Returns
    -------
    Plan
        ``plan.describe()`` is the text of ``splatlab plan SCENE``.
    """
    rule = scene.camera.plan(scene)
    r = scene.render
    moves = scene_moves(scene)
    effects = {"dof": rule["dof"], "motion": describe_motion(scene),
               "medium": "none" if scene.medium is None else scene.medium.describe(), "chromatic": "none",
               "aperture": rule["aperture"], **rule.get("effects", {})}
    skipped = list(rule["skipped"])
    if effects["chromatic"] == "none":
        skipped.append(Step("chromatic aberration", "the camera has no glass (thin lens or pinhole)"))
    if not moves:
        skipped.insert(len(rule["skipped"]), Step("motion blur", "nothing moves while the shutter is open"))
    if scene.medium is None:
        skipped.append(Step("participating medium", "the scene has no medium"))
    if rule["aperture"] == "circle":
        skipped.append(Step("polygonal bokeh (MHU21)", "the thin-lens aperture is a circle"))
    rule = _with_depth_layers(rule, scene, skipped)
    unused = sorted(set(scene.psf) - set(rule["psf_models"]))
    if unused:
        skipped.append(Step(f"[psf.{', psf.'.join(unused)}]", "given in the scene but not needed by "
                                                             "this camera"))
    inputs = (Step("pinhole_labelled", f"pinhole R,G,B ({r.input_spp} spp), A, planar Z at pixel "
                                       "centres, camera in the EXR header"
                   + (", at mid-shutter with motion.X, motion.Y (open -> close)" if moves else "")
                   + (", with a guard band of the largest |CoC| + half the largest motion around the frame "
                      "(LSR18 Boundary; the runtime crops it)" if r.guard_band else "")),)
    if r.peel_layers is not None:
        inputs += (Step("peeled_layers", f"layer0..{r.peel_layers - 1}.R,G,B,A,Z (layer 0: the input; behind it "
                                         f"{r.peel_spp or r.input_spp} spp): LES10's "
                                         "depth peeling from the lens centre past the umbra offset"),)
    if r.peel_layers is not None and "layered" not in rule["runtime_passes"]:
        skipped.append(Step("layered (lens rays through the peeled layers)", "this camera's plan traces no "
                                                                            "lens rays (a round thin lens only)"))
    layers = scene.input_layers()
    if layers and moves:
        raise UserError(f"{scene.source} [[shapes]] layer: the layered input shows one instant and the scene "
                        "moves; remove the layer keys or the velocities")
    if layers:
        inputs += (Step("layered_labelled", f"layer0..{len(layers) - 1}.R,G,B,A,Z ({r.input_spp} spp): "
                                            "the [[shapes]] layer keys, untagged shapes and sky last"),)
        runs = rule.get("pass_runs", {})
        if not any(runs.get(p, (p, {}))[1].get("layered_input") for p in rule["runtime_passes"]):
            skipped.append(Step("layered input in the runtime", "no pass of this plan reads the input's layers"))
    return Plan(scene=scene.name, source=scene.source, resolution=scene.info.resolution,
                effects=effects, psf_models=rule["psf_models"], references=rule["references"],
                inputs=inputs, runtime_passes=rule["runtime_passes"], skipped=tuple(skipped),
                pass_runs=dict(rule.get("pass_runs", {})))
