"""A render whose colour channels see different wavelengths: one pass set per channel.

Mitsuba's RGB variant carries no wavelength, so a camera with dispersion (the thick lens's
Sellmeier glass) is rendered once per channel at that channel's wavelength: pass set c has the
sensor's ``wavelength_nm`` set to ``wavelengths_nm[c]`` (the pass's variant) and weight
``spp`` in channel c and 0 in the others, so the generic average (:func:`lab.reference.passes.
average`) keeps red from the 650 nm renders, green from 510 nm and blue from 475 nm.

The channels' passes share their seeds: the same paths through a slightly different lens, so
the noise of a grey surface stays grey instead of breaking into colour speckle.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .backend import load_scene_dict
from .passes import RenderJob, RenderPass, launch, pass_seeds, split_spp

__all__ = ["ChromaticJob"]


@dataclass
class ChromaticJob(RenderJob):
    """:class:`RenderJob` with one pass set per colour channel (``spp`` samples each).

    Parameters
    ----------
    wavelengths_nm : (float, float, float)
        The R, G and B channels' wavelengths, set as the scene sensor's ``wavelength_nm``.

    The other parameters are :class:`RenderJob`'s. Picklable; each wavelength's Mitsuba scene is
    loaded on first use in a process.
    """

    wavelengths_nm: tuple = (650.0, 510.0, 475.0)
    _scenes: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __getstate__(self):
        return super().__getstate__() | {"_scenes": {}}

    def passes(self) -> list[RenderPass]:
        """Chunk by chunk, the R, G and B pass of each chunk (same seed), in averaging order."""
        chunks = split_spp(self.spp, *self.size, self.pass_spp, one_thread=self.crop is not None)
        seeds = pass_seeds(self.scene.render.seed, self.stream, len(chunks))
        out = []
        for n, seed in zip(chunks, seeds):
            for c, nm in enumerate(self.wavelengths_nm):
                weight = tuple(float(n) if k == c else 0.0 for k in range(3))
                out.append(RenderPass(len(out), n, seed, weight, (("wavelength_nm", float(nm)),)))
        return out

    def mitsuba_scene(self, wavelength_nm: float):
        """The loaded Mitsuba scene whose sensor traces ``wavelength_nm`` (loaded once per process)."""
        if wavelength_nm not in self._scenes:
            from .mitsuba_scene import scene_dict

            data = scene_dict(self.scene, self.sensor, medium=self.medium, crop=self.crop)
            data["sensor"]["wavelength_nm"] = float(wavelength_nm)
            self._scenes[wavelength_nm] = load_scene_dict(data)
        return self._scenes[wavelength_nm]

    def render(self, p: RenderPass) -> np.ndarray:
        """One pass at its wavelength: (H, W, 3) float32 (the average keeps its channel)."""
        return launch(self.mitsuba_scene(p.get("wavelength_nm")), p.spp, p.seed, one_thread=self.one_thread(p))
