"""The references a plan can ask for, by the name of its step: how each is rendered.

A camera's plan rule names its reference (``plan.references[0]``); this table says what renders
it. A new reference (motion sub-frames, a thick-lens sensor, volpath) is a function here, or in a
module of its own imported here, and its entry in :data:`REFERENCES`.
"""
from __future__ import annotations

import numpy as np

from ..errors import UserError

__all__ = ["REFERENCES", "render_reference_step"]


def _mitsuba(scene, image, progress: bool) -> np.ndarray:
    """A Mitsuba path trace through the scene camera's own sensor (thin lens, iris, shape) and its
    medium (volpath)."""
    from .render import render_reference

    return render_reference(scene, progress=progress)


def _motion(scene, image, progress: bool) -> np.ndarray:
    """Sub-frames over the shutter through the scene camera's own sensor, one per pixel of the
    input's longest motion vector (:mod:`lab.reference.motion`)."""
    from ..runtime_passes import read_motion
    from .motion import MotionJob, subframes_for

    flow = read_motion(image, scene.source, "combined")
    job = MotionJob(scene, scene.render.reference_spp, "reference", "scene", desc=f"reference {scene.name}",
                    subframes=subframes_for(float(np.hypot(flow[..., 0], flow[..., 1]).max())))
    return job.run(progress)


def _the_input(scene, image, progress: bool) -> np.ndarray:
    """A pinhole camera: its labelled-pixel input is the ground truth (every PSF is a delta)."""
    return image.rgb


# Step name -> renderer(scene, labelled input, progress) -> (H, W, 3) radiance.
REFERENCES = {"mitsuba_thinlens": _mitsuba, "mitsuba_polygon_lens": _mitsuba, "mitsuba_aperture_lens": _mitsuba,
              "mitsuba_volpath": _mitsuba, "mitsuba_motion": _motion, "pinhole": _the_input}


def render_reference_step(name: str, scene, image, progress: bool = True) -> np.ndarray:
    """Render the reference step ``name`` of a plan for ``scene`` (``image``: its labelled input)."""
    if name not in REFERENCES:
        raise UserError(f"reference {name!r}: no renderer is registered for it; known references are "
                        f"{sorted(REFERENCES)}")
    return REFERENCES[name](scene, image, progress)
