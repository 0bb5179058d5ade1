"""Path-traced renders of a scene with Mitsuba 3: the reference and the pinhole colour.

Renders run in passes of at most :data:`lab.reference.passes.MAX_SAMPLES_PER_PASS` samples
(bounded memory, a progress bar that moves), each pass with its own seed; the passes are averaged
weighted by their spp, which is the same estimator as one render with all the samples
(:mod:`lab.reference.passes`).
"""
from __future__ import annotations

import numpy as np
from tqdm import tqdm

from ..scene import Scene
from .backend import load_scene_dict, mitsuba
from .mitsuba_scene import scene_dict
from .passes import Accumulator, RenderJob, RenderPass, pass_seeds, split_spp  # noqa: F401 (re-exported)


def render_passes(mi_scene, spp: int, seed: int, stream: str, pass_spp: int | None = None,
                  progress: bool = True, desc: str = "render") -> np.ndarray:
    """Render an already loaded Mitsuba scene with ``spp`` samples in seeded passes.

    Parameters
    ----------
    mi_scene : mitsuba.Scene
        From :func:`load`.
    spp : int
        Total samples per pixel.
    seed : int
        Scene seed; each pass gets its own from :func:`~lab.reference.passes.pass_seeds`.
    stream : {"reference", "input", "layers"}
    pass_spp : int, optional
        See :func:`~lab.reference.passes.split_spp`.
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
    passes = [RenderPass(i, n, s, (float(n),) * 3)
              for i, (n, s) in enumerate(zip(chunks, pass_seeds(seed, stream, len(chunks))))]
    acc = Accumulator()
    with tqdm(total=spp, unit="spp", desc=desc, disable=not progress, leave=False) as bar:
        for p in passes:
            acc.add(p, np.asarray(mitsuba().render(mi_scene, spp=p.spp, seed=p.seed), dtype=np.float32))
            bar.update(p.spp)
    return acc.mean()


def load(scene: Scene, sensor: str = "scene", medium: bool = False):
    """``mi.load_dict`` of :func:`~lab.reference.mitsuba_scene.scene_dict`."""
    return load_scene_dict(scene_dict(scene, sensor, medium=medium))


def reference_job(scene: Scene, spp: int | None = None, pass_spp: int | None = None) -> RenderJob:
    """The path-traced reference through the scene's own camera (thin lens or pinhole), and
    through the scene's ``[medium]`` if it has one (``volpath``), as a job of seeded passes.

    Parameters
    ----------
    scene : Scene
    spp : int, optional
        Samples per pixel; default ``scene.render.reference_spp``.
    pass_spp : int, optional
        Samples per pass (a power of two); default keeps a pass at <= 2^24 samples (16 spp at
        1024^2), see :func:`~lab.reference.passes.split_spp`.
    """
    spp = scene.render.reference_spp if spp is None else spp
    return RenderJob(scene, spp, "reference", "scene", medium=True, pass_spp=pass_spp,
                     desc=f"reference {scene.name}")


def render_reference(scene: Scene, spp: int | None = None, pass_spp: int | None = None,
                     progress: bool = True) -> np.ndarray:
    """:func:`reference_job` rendered here, pass after pass (tqdm bar on stderr if ``progress``).
    (H, W, 3) float32 linear radiance."""
    return reference_job(scene, spp, pass_spp).run(progress)


def render_pinhole(scene: Scene, spp: int | None = None, pass_spp: int | None = None,
                   progress: bool = True) -> np.ndarray:
    """The pinhole colour (same view and fov as the scene's camera), ``scene.render.input_spp``
    samples by default, from the ``input`` seed stream. (H, W, 3) float32."""
    spp = scene.render.input_spp if spp is None else spp
    return RenderJob(scene, spp, "input", "pinhole", pass_spp=pass_spp, desc=f"pinhole {scene.name}").run(progress)
