"""Which layered tracer traces a camera's lens rays: one entry per header lens (``"lens"``).

``tracer_for(camera, shape, n_layers, rays, **options)`` returns an object with
``render(stack, thickness_px, seed) -> (image, info)``; a lens with no entry (the pinhole: it has
no lens to trace) is refused with the lenses that have one.
"""
from __future__ import annotations

from runtime_cl.errors import InputError
from runtime_cl.layered.thick_tracer import ThickLayerTracer
from runtime_cl.layered.tracer import LayerTracer

__all__ = ["check_lens", "tracer_for", "lens_names"]


class ThinRays:
    """A thin lens: rays from the unit disc scaled by the CoC (:class:`LayerTracer`)."""

    def __init__(self, camera, shape, n_layers, rays, **options):
        self.camera = camera
        self.tracer = LayerTracer(shape, n_layers, rays, **options)
        # A tilted or expressive focus: each pixel's own 1/F (ThinLens.inverse_focus_map)
        self.focus = camera.inverse_focus_map(*shape) if getattr(camera, "has_focal_map", False) else None

    def render(self, stack, thickness_px, seed):
        scale = float(self.camera.coc_scale_px(stack.shape[1]))
        return self.tracer.render(stack, scale, float(self.camera.focus_distance_m), thickness_px, seed,
                                  inv_focus_map=self.focus)


class ThickRays:
    """A thick lens: rays traced through its surfaces per channel (:class:`ThickLayerTracer`)."""

    def __init__(self, camera, shape, n_layers, rays, **options):
        self.tracer = ThickLayerTracer(camera, shape, n_layers, rays, **options)

    def render(self, stack, thickness_px, seed):
        return self.tracer.render(stack, thickness_px, seed)


TRACERS = {"thin": ThinRays, "thick": ThickRays}


def lens_names() -> list:
    return sorted(TRACERS)


def check_lens(camera) -> str:
    """``camera``'s lens name if a layered tracer traces it, else InputError naming the others."""
    lens = getattr(camera, "lens", None)
    if lens not in TRACERS:
        raise InputError(f"camera lens {lens!r}: the layered pass traces lens rays of {lens_names()} lenses; "
                         "render a pinhole input with the spreadlet passes instead")
    return lens


def tracer_for(camera, shape, n_layers: int, rays: int, **options):
    """The layered tracer of ``camera``'s lens (see the module docstring)."""
    return TRACERS[check_lens(camera)](camera, shape, n_layers, rays, **options)
