"""The identity pass: a pinhole camera's image is its own depth of field (every PSF a delta)."""
from __future__ import annotations

import numpy as np

from runtime_cl.passes.registry import RuntimePass, register_pass
from runtime_cl.timing import CallTimes

__all__ = ["IdentityPass"]


@register_pass("identity")
class IdentityPass(RuntimePass):
    """Returns the input colour unchanged (a pinhole camera: no defocus, nothing to splat)."""

    summary = "the input unchanged (pinhole camera: every PSF is a delta)"
    database_models = ()
    channels = ("R", "G", "B")
    layered = False

    def prepare(self, frame):
        return np.asarray(frame.rgb, np.float32)

    def __call__(self, prepared):
        return prepared.copy(), CallTimes(counts={"pixels": int(prepared.shape[0] * prepared.shape[1])})
