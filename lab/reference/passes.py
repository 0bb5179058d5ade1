"""A path-traced render as independent, seeded passes, averaged in a fixed order.

A :class:`RenderJob` lists its passes (:meth:`RenderJob.passes`) and renders any one of them on
its own (:meth:`RenderJob.render`): a pass is a seed, a sample count and a *variant* -- what the
pass changes in the scene (a motion sub-frame's shutter time, a thick lens's wavelength). The
result is the per-channel weighted mean of the pass images, accumulated in float64 in pass
order (:func:`average`), so it does not depend on where or in which order the passes ran.

Subclasses change what a pass is: :mod:`lab.reference.motion` (sub-frames), the thick-lens
sensor (one wavelength per channel). Executors (serial here; local processes or Dask in
:mod:`lab.reference.execute`) only call ``job.render(p)`` for each ``p`` in ``job.passes()``
and add the images to an :class:`Accumulator` in pass order.

A pass image must also not depend on the Dr.Jit thread count of the process that renders it
(a worker has fewer threads than a serial run). Mitsuba adds each sample into its pixel with an
atomic float add; Dr.Jit splits a launch into work blocks, one thread each: 16384 lanes for
launches of more than ``2 * 16384 * threads`` lanes, otherwise blocks sized by the thread count
in whole SIMD packets (4, 8 or 16 lanes). A pixel's ``spp`` consecutive samples summed by two
threads come out in a scheduling-dependent order (measured: a few pixels per pass differ in the
last bits at 7 or 12 spp, and at 32 spp on 25x23 pixels). They stay in one block, so in one
thread's fixed order, when ``spp`` is a power of two and either at most 4 (within one SIMD
packet) or the launch has at least :data:`FIXED_BLOCK_LANES` samples (fixed blocks, for up to
128 threads). :func:`split_spp` makes such passes and :class:`RenderPass` refuses other ``spp``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from tqdm import tqdm

from ..scene import Scene
from .backend import mitsuba

__all__ = ["Accumulator", "RenderPass", "RenderJob", "average", "pass_seeds", "split_spp", "MAX_SAMPLES_PER_PASS",
           "FIXED_BLOCK_LANES"]

MAX_SAMPLES_PER_PASS = 1 << 24  # 16 spp at 1024^2
FIXED_BLOCK_LANES = 1 << 22     # 2 * 16384 lanes * 128 threads: Dr.Jit's fixed-size work blocks
_DRJIT_BLOCK = 1 << 14          # lanes per work block of a large launch
_SIMD_SAFE_SPP = 4              # samples that always fit one SIMD packet
STREAMS = {"reference": 0, "input": 1, "layers": 2}


def pass_seeds(seed: int, stream: str, n_passes: int) -> list[int]:
    """Distinct 32-bit Mitsuba seeds, one per pass, for one render stream.

    Parameters
    ----------
    seed : int
        The scene's ``[render] seed``.
    stream : {"reference", "input", "layers"}
        Separate streams so the reference and the inputs never share noise.
    n_passes : int
    """
    states = np.random.SeedSequence([seed, STREAMS[stream]]).generate_state(n_passes)
    return [int(s) for s in states]


def _power_of_two(n) -> bool:
    return isinstance(n, int) and n >= 1 and n & (n - 1) == 0


def split_spp(spp: int, width: int, height: int, pass_spp: int | None = None) -> list[int]:
    """Split ``spp`` samples per pixel into passes whose images do not depend on the thread count.

    Parameters
    ----------
    spp : int
        Total samples per pixel (>= 1).
    width, height : int
        Image size in pixels.
    pass_spp : int, optional
        Samples per pass, a power of two; default: the largest power of two (at most 16384) whose
        pass fits in ``MAX_SAMPLES_PER_PASS`` samples.

    Returns
    -------
    list of int
        Full passes, then the remainder as descending powers of two, summing to ``spp``. A pass of
        more than 4 spp with fewer than :data:`FIXED_BLOCK_LANES` samples is split into 4-spp
        passes (see the module docstring).
    """
    if spp < 1:
        raise ValueError(f"spp = {spp} must be >= 1")
    if pass_spp is None:
        fit = max(1, MAX_SAMPLES_PER_PASS // (width * height))
        pass_spp = min(_DRJIT_BLOCK, 1 << (fit.bit_length() - 1))
    elif not _power_of_two(pass_spp) or pass_spp > _DRJIT_BLOCK:
        raise ValueError(f"pass_spp = {pass_spp} must be a power of two (1, 2, 4, ..., {_DRJIT_BLOCK}), "
                         "so that each pass image is the same whatever Dr.Jit thread count renders it")
    n, rest = divmod(spp, pass_spp)
    chunks = [pass_spp] * n + [1 << b for b in reversed(range(rest.bit_length())) if rest >> b & 1]
    return [part for c in chunks for part in (
        [_SIMD_SAFE_SPP] * (c // _SIMD_SAFE_SPP) if c > _SIMD_SAFE_SPP and width * height * c < FIXED_BLOCK_LANES
        else [c])]


@dataclass(frozen=True)
class RenderPass:
    """One seeded render of a job.

    Attributes
    ----------
    index : int
        Position in the job's pass list (the order of :func:`average`).
    spp : int
        Samples per pixel of this pass.
    seed : int
        Mitsuba seed (distinct per pass, :func:`pass_seeds`).
    weight : (float, float, float)
        Weight of this pass's R, G, B in the average: ``spp`` for a plain pass; ``(spp, 0, 0)``
        for a pass that only renders the red channel's wavelength.
    variant : tuple of (str, value) pairs
        What the pass changes in the scene, e.g. ``(("time", 0.25),)``; empty for a plain pass.
    """

    index: int
    spp: int
    seed: int
    weight: tuple[float, float, float]
    variant: tuple = ()

    def __post_init__(self):
        if not _power_of_two(self.spp) or self.spp > _DRJIT_BLOCK:
            raise ValueError(f"pass {self.index}: spp = {self.spp!r} must be a power of two <= "
                             f"{_DRJIT_BLOCK} (lab.reference.passes.split_spp makes such passes), "
                             "or its image depends on the Dr.Jit thread count that renders it")

    def get(self, key: str, default=None):
        """The variant's value for ``key``."""
        return dict(self.variant).get(key, default)


class Accumulator:
    """The per-channel weighted mean of pass images, summed in float64 in the order added.

    Executors add passes in index order (buffering any that finish early), so the mean is
    bitwise the same however the passes were spread over processes.
    """

    def __init__(self):
        self.total, self.weights, self.count = None, np.zeros(3), 0

    def add(self, p: RenderPass, image) -> None:
        if p.index != self.count:
            raise ValueError(f"pass {p.index} added as number {self.count}; add passes in index order")
        w = np.asarray(p.weight, dtype=np.float64)
        term = np.asarray(image, dtype=np.float64)[..., :3] * w
        self.total = term if self.total is None else self.total + term
        self.weights += w
        self.count += 1

    def mean(self) -> np.ndarray:
        """(H, W, 3) float32; ValueError if a channel has no weight."""
        if self.total is None:
            raise ValueError("no passes to average")
        if not np.all(self.weights > 0):
            raise ValueError(f"channel weights {self.weights.tolist()}: every channel needs a pass")
        return (self.total / self.weights).astype(np.float32)


def average(passes, images) -> np.ndarray:
    """:class:`Accumulator` over ``passes`` and their ``images`` (same order). (H, W, 3) float32."""
    acc = Accumulator()
    for p, img in zip(passes, images):
        acc.add(p, img)
    return acc.mean()


@dataclass
class RenderJob:
    """A plain render of ``scene``: ``spp`` samples split into seeded passes.

    Parameters
    ----------
    scene : Scene
    spp : int
        Total samples per pixel.
    stream : {"reference", "input", "layers"}
        The seed stream (:func:`pass_seeds`).
    sensor : {"scene", "pinhole"}
        The scene camera's own sensor, or a pinhole with the same view.
    medium : bool
        Render through the scene's ``[medium]`` (the reference), see
        :func:`lab.reference.mitsuba_scene.scene_dict`.
    pass_spp : int, optional
        Samples per pass (:func:`split_spp`).
    desc : str
        Progress bar label.

    The job is picklable (process and Dask executors send it); the Mitsuba scene is loaded
    lazily, once per process.
    """

    scene: Scene
    spp: int
    stream: str = "reference"
    sensor: str = "scene"
    medium: bool = False
    pass_spp: int | None = None
    desc: str = "render"
    _loaded: object = field(default=None, init=False, repr=False, compare=False)

    def __getstate__(self):
        return {k: v for k, v in self.__dict__.items() if k != "_loaded"} | {"_loaded": None}

    def passes(self) -> list[RenderPass]:
        """The seeded passes (full ones, then the remainder), in averaging order."""
        chunks = split_spp(self.spp, self.scene.width, self.scene.height, self.pass_spp)
        seeds = pass_seeds(self.scene.render.seed, self.stream, len(chunks))
        return [RenderPass(i, n, s, (float(n),) * 3) for i, (n, s) in enumerate(zip(chunks, seeds))]

    def mitsuba_scene(self):
        """The loaded Mitsuba scene (loaded on first use in this process)."""
        if self._loaded is None:
            from .mitsuba_scene import scene_dict

            self._loaded = mitsuba().load_dict(scene_dict(self.scene, self.sensor, medium=self.medium))
        return self._loaded

    def render(self, p: RenderPass) -> np.ndarray:
        """One pass: (H, W, 3) float32 mean radiance of its ``spp`` samples."""
        img = mitsuba().render(self.mitsuba_scene(), spp=p.spp, seed=p.seed)
        return np.asarray(img, dtype=np.float32)[..., :3]

    def run(self, progress: bool = True) -> np.ndarray:
        """Render every pass here, in order, and :func:`average` them. (H, W, 3) float32."""
        passes, acc = self.passes(), Accumulator()
        with tqdm(total=sum(p.spp for p in passes), unit="spp", desc=self.desc, disable=not progress,
                  leave=False) as bar:
            for p in passes:
                acc.add(p, self.render(p))
                bar.update(p.spp)
        return acc.mean()
