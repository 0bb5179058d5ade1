"""Path-traced renders of a scene with Mitsuba 3: the reference and the pinhole colour.

Renders run in passes of at most ``MAX_SAMPLES_PER_PASS`` samples (bounded memory, a progress bar
that moves), each pass with its own seed; the passes are averaged weighted by their spp, which is
the same estimator as one render with all the samples.
"""
from __future__ import annotations

import numpy as np
from tqdm import tqdm

from ..scene import Scene
from .backend import mitsuba
from .mitsuba_scene import scene_dict

MAX_SAMPLES_PER_PASS = 1 << 24  # 16 spp at 1024^2
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


def split_spp(spp: int, width: int, height: int, pass_spp: int | None = None) -> list[int]:
    """Split ``spp`` samples per pixel into passes.

    Parameters
    ----------
    spp : int
        Total samples per pixel (>= 1).
    width, height : int
        Image size in pixels.
    pass_spp : int, optional
        Samples per pass; default: as many as fit in ``MAX_SAMPLES_PER_PASS`` samples.

    Returns
    -------
    list of int
        Full passes then the remainder, summing to ``spp``.
    """
    if spp < 1:
        raise ValueError(f"spp = {spp} must be >= 1")
    if pass_spp is None:
        pass_spp = max(1, MAX_SAMPLES_PER_PASS // (width * height))
    pass_spp = max(1, min(pass_spp, spp))
    n, rest = divmod(spp, pass_spp)
    return [pass_spp] * n + ([rest] if rest else [])


def render_passes(mi_scene, spp: int, seed: int, stream: str, pass_spp: int | None = None,
                  progress: bool = True, desc: str = "render") -> np.ndarray:
    """Render a loaded Mitsuba scene with ``spp`` samples in seeded passes.

    Parameters
    ----------
    mi_scene : mitsuba.Scene
        From :func:`load`.
    spp : int
        Total samples per pixel.
    seed : int
        Scene seed; each pass gets its own from :func:`pass_seeds`.
    stream : {"reference", "input"}
    pass_spp : int, optional
        See :func:`split_spp`.
    progress : bool
        Show a tqdm bar (samples per pixel done) on stderr.
    desc : str
        The bar's label.

    Returns
    -------
    (H, W, 3) float32
        The spp-weighted mean of the passes: the same estimator as one render of ``spp``.
    """
    size = mi_scene.sensors()[0].film().size()
    chunks = split_spp(spp, int(size[0]), int(size[1]), pass_spp)
    total = None
    with tqdm(total=spp, unit="spp", desc=desc, disable=not progress, leave=False) as bar:
        for n, s in zip(chunks, pass_seeds(seed, stream, len(chunks))):
            img = np.asarray(mitsuba().render(mi_scene, spp=n, seed=s), dtype=np.float64)
            total = img * n if total is None else total + img * n
            bar.update(n)
    return (total / spp)[..., :3].astype(np.float32)


def load(scene: Scene, sensor: str = "scene", medium: bool = False):
    """``mi.load_dict`` of :func:`~lab.reference.mitsuba_scene.scene_dict`."""
    return mitsuba().load_dict(scene_dict(scene, sensor, medium=medium))


def render_reference(scene: Scene, spp: int | None = None, pass_spp: int | None = None,
                     progress: bool = True) -> np.ndarray:
    """The path-traced reference through the scene's own camera (thin lens or pinhole), and
    through the scene's ``[medium]`` if it has one (``volpath``).

    Parameters
    ----------
    scene : Scene
    spp : int, optional
        Samples per pixel; default ``scene.render.reference_spp``.
    pass_spp : int, optional
        Samples per pass; default keeps a pass at <= 2^24 samples (16 spp at 1024^2).
    progress : bool
        Show a tqdm bar on stderr.

    Returns
    -------
    (H, W, 3) float32 linear radiance.
    """
    spp = scene.render.reference_spp if spp is None else spp
    return render_passes(load(scene, "scene", medium=True), spp, scene.render.seed, "reference", pass_spp,
                         progress, desc=f"reference {scene.name}")


def render_pinhole(scene: Scene, spp: int | None = None, pass_spp: int | None = None,
                   progress: bool = True) -> np.ndarray:
    """The pinhole colour (same view and fov as the scene's camera), ``scene.render.input_spp``
    samples by default, from the ``input`` seed stream. (H, W, 3) float32."""
    spp = scene.render.input_spp if spp is None else spp
    return render_passes(load(scene, "pinhole"), spp, scene.render.seed, "input", pass_spp,
                         progress, desc=f"pinhole {scene.name}")
