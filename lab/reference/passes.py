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

A job that renders a film crop (:attr:`RenderJob.crop`: an adaptive reference's tiles, a few
thousand pixels) would need hundreds of such 4-spp launches, each costing more in launch overhead
than in samples; its passes instead render on one Dr.Jit thread (:func:`launch`), where every
sample is added in one fixed order, so any power-of-two ``spp`` gives the same image everywhere
(``split_spp(..., one_thread=True)``), unless they are large enough for the fixed blocks
(:meth:`RenderJob.one_thread`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from tqdm import tqdm

from ..scene import Scene
from .backend import load_scene_dict, mitsuba

__all__ = ["Accumulator", "RenderPass", "RenderJob", "average", "launch", "pass_seeds", "split_spp",
           "MAX_SAMPLES_PER_PASS",
           "FIXED_BLOCK_LANES"]

MAX_SAMPLES_PER_PASS = 1 << 24  # 16 spp at 1024^2
FIXED_BLOCK_LANES = 1 << 22     # 2 * 16384 lanes * 128 threads: Dr.Jit's fixed-size work blocks
_DRJIT_BLOCK = 1 << 14          # lanes per work block of a large launch
_SIMD_SAFE_SPP = 4              # samples that always fit one SIMD packet
STREAMS = {"reference": 0, "input": 1, "layers": 2, "pilot": 3, "adaptive": 4}


def pass_seeds(seed: int, stream, n_passes: int) -> list[int]:
    """Distinct 32-bit Mitsuba seeds, one per pass, for one render stream.

    Parameters
    ----------
    seed : int
        The scene's ``[render] seed``.
    stream : {"reference", "input", "layers", "pilot"} or ("adaptive", int)
        Separate streams so the reference and the inputs never share noise; an adaptive
        reference's pilot and each of its refined tiles (:mod:`lab.reference.adaptive`) draw their own.
    n_passes : int
    """
    name, *more = (stream,) if isinstance(stream, str) else tuple(stream)
    states = np.random.SeedSequence([seed, STREAMS[name], *(int(m) for m in more)]).generate_state(n_passes)
    return [int(s) for s in states]


def _power_of_two(n) -> bool:
    return isinstance(n, int) and n >= 1 and n & (n - 1) == 0


def split_spp(spp: int, width: int, height: int, pass_spp: int | None = None, one_thread: bool = False) -> list[int]:
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
    one_thread : bool, default False
        The passes render on one thread (:func:`launch`): no 4-spp split is needed.

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
        [_SIMD_SAFE_SPP] * (c // _SIMD_SAFE_SPP)
        if not one_thread and c > _SIMD_SAFE_SPP and width * height * c < FIXED_BLOCK_LANES else [c])]


def launch(mi_scene, spp: int, seed: int, one_thread: bool = False) -> np.ndarray:
    """``mi.render`` of a loaded scene: (H, W, 3) float32. ``one_thread``: on one Dr.Jit thread (the
    pool restored after), so the image does not depend on the thread count whatever ``spp`` is."""
    if not one_thread:
        return np.asarray(mitsuba().render(mi_scene, spp=spp, seed=seed), dtype=np.float32)[..., :3]
    import drjit as dr

    threads = dr.thread_count()
    dr.set_thread_count(1)
    try:
        return np.asarray(mitsuba().render(mi_scene, spp=spp, seed=seed), dtype=np.float32)[..., :3]
    finally:
        dr.set_thread_count(threads)


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
    bitwise the same however the passes were spread over processes. It also sums the weighted
    squares, so :meth:`variance` estimates the mean's variance from the spread between passes.
    """

    def __init__(self):
        self.total, self.squares, self.weights, self.count = None, None, np.zeros(3), 0
        self.counts = np.zeros(3)   # passes with weight in each channel

    def add(self, p: RenderPass, image) -> None:
        if p.index != self.count:
            raise ValueError(f"pass {p.index} added as number {self.count}; add passes in index order")
        w = np.asarray(p.weight, dtype=np.float64)
        x = np.asarray(image, dtype=np.float64)[..., :3]
        term = x * w
        self.total = term if self.total is None else self.total + term
        self.squares = term * x if self.squares is None else self.squares + term * x
        self.weights += w
        self.counts += w > 0
        self.count += 1

    def variance(self) -> np.ndarray:
        """(H, W, 3) float64: an unbiased estimate of the variance of :meth:`mean` per pixel.

        Pass i is the mean of ``w_i`` i.i.d. samples of variance s^2, so its image X_i has variance
        s^2 / w_i and E[sum_i w_i (X_i - mean)^2] = (P - 1) s^2 over P passes; the mean of all
        W = sum w_i samples has variance s^2 / W. Passes that differ in what they render (motion
        sub-frames) add their differences to this spread: an over-estimate there.
        """
        if self.total is None or not np.all(self.counts >= 2):
            raise ValueError(f"{self.counts.tolist()} passes per channel: the spread needs at least 2 each")
        w = self.weights
        spread = np.maximum(self.squares - self.total ** 2 / w, 0.0)   # sum_i w_i (X_i - mean)^2
        return spread / (self.counts - 1) / w

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
    crop : (x, y, width, height), optional
        Render only this window of the film (pixels; Mitsuba's film crop): images are
        (height, width, 3), and the window's pixels are sampled exactly as in the whole frame.

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
    crop: tuple | None = None
    _loaded: object = field(default=None, init=False, repr=False, compare=False)

    def __getstate__(self):
        return {k: v for k, v in self.__dict__.items() if k != "_loaded"} | {"_loaded": None}

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) of the images this job renders: the crop's, else the scene's."""
        return (self.scene.width, self.scene.height) if self.crop is None else tuple(self.crop[2:])

    def passes(self) -> list[RenderPass]:
        """The seeded passes (full ones, then the remainder), in averaging order."""
        chunks = split_spp(self.spp, *self.size, self.pass_spp, one_thread=self.crop is not None)
        seeds = pass_seeds(self.scene.render.seed, self.stream, len(chunks))
        return [RenderPass(i, n, s, (float(n),) * 3) for i, (n, s) in enumerate(zip(chunks, seeds))]

    def mitsuba_scene(self):
        """The loaded Mitsuba scene (loaded on first use in this process)."""
        if self._loaded is None:
            from .mitsuba_scene import scene_dict

            self._loaded = load_scene_dict(scene_dict(self.scene, self.sensor, medium=self.medium, crop=self.crop))
        return self._loaded

    def render(self, p: RenderPass) -> np.ndarray:
        """One pass: (H, W, 3) float32 mean radiance of its ``spp`` samples."""
        return launch(self.mitsuba_scene(), p.spp, p.seed, one_thread=self.one_thread(p))

    def one_thread(self, p: RenderPass) -> bool:
        """Whether pass ``p`` renders on one thread: a crop's pass below :data:`FIXED_BLOCK_LANES`
        samples (larger ones use Dr.Jit's fixed blocks, the same on any thread count)."""
        w, h = self.size
        return self.crop is not None and w * h * p.spp < FIXED_BLOCK_LANES

    def run(self, progress: bool = True) -> np.ndarray:
        """Render every pass here, in order, and :func:`average` them. (H, W, 3) float32."""
        passes, acc = self.passes(), Accumulator()
        with tqdm(total=sum(p.spp for p in passes), unit="spp", desc=self.desc, disable=not progress,
                  leave=False) as bar:
            for p in passes:
                acc.add(p, self.render(p))
                bar.update(p.spp)
        return acc.mean()
