"""The references a plan can ask for, by the name of its step: what renders each.

A camera's plan rule names its reference (``plan.references[0]``); :data:`REFERENCES` maps the
name to a function of (scene, labelled input) that returns either a
:class:`~lab.reference.passes.RenderJob` -- seeded passes that :func:`lab.reference.execute.run_job`
renders here, in local worker processes or on Dask, caching each pass -- or, when nothing needs
rendering, the reference image itself. A new reference (motion sub-frames, a thick-lens sensor)
is a function here, or a module of its own imported here (usually a ``RenderJob`` subclass), and
its entry in :data:`REFERENCES`. Nothing here runs a job, so how it runs is not part of the
reference's cache key.
"""
from __future__ import annotations

import numpy as np

from ..errors import UserError

__all__ = ["REFERENCES", "reference_step"]


def _mitsuba(scene, image):
    """A Mitsuba path trace through the scene camera's own sensor (thin lens, iris, shape) and its
    medium (volpath)."""
    from .render import reference_job

    return reference_job(scene)


def _through_medium(scene, image):
    """Through the medium (filling the scene or a box), the equi-angular estimator
    (:mod:`lab.reference.equiangular`: volpath's image with far less noise); through a medium that
    neither scatters nor absorbs (``sigma_t`` 0), Mitsuba's ``volpath``."""
    from .equiangular import EquiAngularJob, applies

    if applies(scene):
        return EquiAngularJob(scene, scene.render.reference_spp, "reference", "scene", medium=True,
                              desc=f"reference {scene.name}")
    return _mitsuba(scene, image)


def _motion(scene, image):
    """Sub-frames over the shutter through the scene camera's own sensor, one per pixel of the
    input's longest motion vector (:mod:`lab.reference.motion`)."""
    from ..motion import read_motion
    from .motion import MotionJob, subframes_for

    flow = read_motion(image, scene.source, "combined")
    return MotionJob(scene, scene.render.reference_spp, "reference", "scene", desc=f"reference {scene.name}",
                     subframes=subframes_for(float(np.hypot(flow[..., 0], flow[..., 1]).max())))


def _thick_lens(scene, image):
    """A Mitsuba path trace through the thick lens (:mod:`lab.reference.thick_lens_sensor`), one
    pass set per channel at the camera's wavelengths (:class:`lab.reference.chromatic.ChromaticJob`)."""
    from ..cameras.thick import WAVELENGTHS_NM
    from .chromatic import ChromaticJob

    return ChromaticJob(scene, scene.render.reference_spp, "reference", "scene", wavelengths_nm=WAVELENGTHS_NM,
                        desc=f"reference {scene.name}")


def _the_input(scene, image) -> np.ndarray:
    """A pinhole camera: its labelled-pixel input is the ground truth (every PSF is a delta)."""
    return image.frame_crop(image.rgb)


def _none(scene, image) -> None:
    """No reference: nothing physical has the plan's effect (an expressive focal surface)."""
    return None


# Step name -> (scene, labelled input) -> RenderJob to run, the (H, W, 3) radiance itself, or None.
REFERENCES = {"none": _none, "mitsuba_thinlens": _mitsuba, "mitsuba_polygon_lens": _mitsuba, "mitsuba_aperture_lens": _mitsuba,
              "volume_path_trace": _through_medium, "mitsuba_motion": _motion, "mitsuba_thick_lens": _thick_lens,
              "pinhole": _the_input}


def reference_step(name: str, scene, image):
    """What the plan's reference step ``name`` is for ``scene`` (``image``: its labelled input): a
    ``RenderJob`` to run, an :class:`~lab.reference.adaptive.AdaptiveJob` around it when the scene
    asks for ``[render] reference_adaptive``, the (H, W, 3) reference image when nothing needs
    rendering, or None when there is no reference (step ``none``)."""
    from .adaptive import AdaptiveJob
    from .passes import RenderJob

    if name not in REFERENCES:
        raise UserError(f"reference {name!r}: no renderer is registered for it; known references are "
                        f"{sorted(REFERENCES)}")
    step = REFERENCES[name](scene, image)
    if isinstance(step, RenderJob) and scene.render.reference_adaptive is not None:
        return AdaptiveJob(step, scene.render.reference_adaptive)
    return step
