"""Reconstruction from a stochastic (1-spp) image: LSR18's spreadlets and Splat on re-centred samples.

The input already holds depth of field and motion blur, sampled once per pixel; its channels
``lens.U, lens.V, time`` say where on the lens and when. :func:`runtime_cl.stochastic.recentre`
moves every pixel back to its surface's position at the lens centre and mid-shutter (LSR18 6.2,
Fig. 7 d-e) as a few frames (slots), which the ordinary spreadlet or Splat pass splats; the sum
is the reconstruction. Splatting the input as it is would apply the blur twice (Fig. 7 c).

Option ``normalize`` (default False: LSR18's plain sum) also splats each entry's sample count
with the same PSFs and divides the colour by that density (at least ``min_density``): the
re-centred samples of one surface lie at random places, so their plain sum fluctuates by about
1 / sqrt(pi r^2) of a CoC of radius r even where the colour is constant; the ratio does not.
Where surfaces of different depths mix (a focused background behind a blurred occluder) the
ratio leans towards the blurred surface, so it trades that noise for a bias there. A medium's
database (``volume``, ``volume_box``) refuses it: its PSFs carry the medium's loss, so the splatted
counts are no density (and its still pinhole puts every sample on its own pixel anyway).

A medium is not in the input (:mod:`lab.reference.stochastic` leaves it out, as from the labelled
input): the volume PSFs add it, and option ``far_field`` the halos beyond their window.

Option ``keep_outside`` (default True): samples re-centred outside the image (they saw a surface
beyond the frame through the lens) are splatted from a margin around it with the camera widened at
the same pixel pitch, and the margin is cropped; False drops them (a tilted or expressive focus
always does: :func:`runtime_cl.stochastic.recentre.recentre`).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from runtime_cl.coords.maps import attenuates
from runtime_cl.errors import InputError
from runtime_cl.passes.registry import register_pass
from runtime_cl.passes.spreadlets import SplatPass, SpreadletsPass
from runtime_cl.stochastic import CHANNELS, recentre
from runtime_cl.stochastic.composite import check_layers, composite, layer_bins
from runtime_cl.stochastic.recentre import FOOTPRINTS, widened
from runtime_cl.timing import CallTimes

__all__ = ["StochasticSpreadletsPass", "StochasticSplatPass"]


class _Stochastic:
    """Re-centre in ``prepare`` (not timed, like the other passes' per-pixel parameters); each
    call splats every slot with the base pass and sums."""

    channels = ("R", "G", "B", "Z") + CHANNELS
    layered = False     # re-centred slots are flat frames: no depth layers of their own
    far_field = True    # the input has no medium (as the labelled input): the volume PSFs add it

    def configure(self, *, normalize: bool = False, min_density: float = 0.25, footprint: str = "nearest",
                  fill: bool = True, depth_layers: int = 1, keep_outside: bool = True, **options):
        if not isinstance(normalize, bool):
            raise InputError(f"normalize = {normalize!r}: give True (divide by the splatted sample density) "
                             "or False (LSR18's plain sum)")
        if isinstance(min_density, bool) or not (isinstance(min_density, (int, float)) and 0 < min_density <= 1):
            raise InputError(f"min_density = {min_density!r}: give a number in (0, 1], the least density "
                             "the normalised reconstruction divides by")
        if footprint not in FOOTPRINTS:
            raise InputError(f"footprint = {footprint!r}: give one of {list(FOOTPRINTS)} (how a re-centred "
                             "sample lands on the pixel grid)")
        if not isinstance(fill, bool):
            raise InputError(f"fill = {fill!r}: give True (fill low sample density from coarser pixels) or False "
                             "(divide by at least min_density)")
        if normalize and attenuates(self.db.model):
            raise InputError(f"normalize = True: a {self.db.model!r} database's PSFs carry the medium's loss, so "
                             "splatting the sample counts with them is no sample density (dividing by it would undo "
                             "the medium); give normalize = False (a medium's camera is a still pinhole: every sample "
                             "is on its own pixel)")
        if check_layers(depth_layers) > 1 and not normalize:
            raise InputError(f"depth_layers = {depth_layers!r}: a layer's opacity is its sample density, which only "
                             "the normalised reconstruction splats; give normalize = True or depth_layers = 1")
        if not isinstance(keep_outside, bool):
            raise InputError(f"keep_outside = {keep_outside!r}: give True (splat the samples re-centred outside "
                             "the image from a margin) or False (drop them)")
        self.normalize, self.min_density, self.footprint, self.fill = normalize, float(min_density), footprint, fill
        self.keep_outside = keep_outside
        self.depth_layers = int(depth_layers)
        super().configure(**options)

    def prepare(self, frame):
        if frame.samples is None:
            raise InputError(f"the {self.name!r} pass reconstructs a stochastic image: it needs the channels "
                             f"{list(CHANNELS)}; give the labelled image those channels, or splat a pinhole "
                             "image with the plain pass")
        rec = recentre(frame, np.asarray(frame.samples, np.float32), self.camera, footprint=self.footprint,
                       keep_outside=self.keep_outside)
        base = self._wide_prepare(np.shape(frame.depth)[1], rec.margin)
        if self.depth_layers == 1:
            slots = [[(f, n) for f, n in zip(rec.frames, rec.counts)]]
        else:   # each slot split by the depth layer of its entries (empty parts skipped)
            width = np.shape(frame.depth)[1]
            bins = layer_bins([self.camera.coc_radius_px(np.asarray(f.depth, np.float64), width) for f in rec.frames],
                              rec.counts, self.depth_layers)
            slots = [[(_masked(f, b == k), n * (b == k)[..., None]) for f, n, b in zip(rec.frames, rec.counts, bins)
                      if np.any(b == k)] for k in range(self.depth_layers)]
            slots = [s for s in slots if s]
        parts = [[base(f) for f, _ in layer] for layer in slots]
        density = [[base(replace(f, rgb=n)) for f, n in layer] for layer in slots] if self.normalize else []
        return rec, parts, density

    def _wide_prepare(self, width: int, margin: int):
        """The base pass's ``prepare`` for frames ``margin`` px wider than the image on every side:
        its PSF coordinates from the camera widened at the same pixel pitch."""
        camera, wide = self.camera, widened(self.camera, width, margin)

        def prepare(f):
            self.camera = wide
            try:
                return super(_Stochastic, self).prepare(f)
            finally:
                self.camera = camera
        return prepare

    def _sum(self, parts, counts: dict):
        total, device, transfer = None, 0.0, 0.0
        for part in parts:
            image, t = super(_Stochastic, self).__call__(part)
            total = image if total is None else total + image
            device, transfer = device + t.device_ms, transfer + t.transfer_ms
            for k, v in t.counts.items():
                counts[k] = counts.get(k, 0) + v
        return total, device, transfer

    def __call__(self, prepared):
        rec, parts, density = prepared
        counts, colours, weights, device, transfer = {}, [], [], 0.0, 0.0
        for layer in parts:
            c, d1, t1 = self._sum(layer, counts)
            colours.append(c)
            device, transfer = device + d1, transfer + t1
        for layer in density:
            w, d2, t2 = self._sum(layer, {})
            weights.append(w)
            device, transfer = device + d2, transfer + t2
        # host work: in the call's time
        total = composite(colours, weights, self.min_density, self.fill) if self.normalize else sum(colours)
        m = rec.margin
        total = np.ascontiguousarray(total[m:total.shape[0] - m, m:total.shape[1] - m])
        counts.update(slots=len(rec.frames), dropped_samples=rec.dropped, depth_layers=len(parts), margin_px=m)
        return total, CallTimes(device_ms=device, transfer_ms=transfer, counts=counts)


def _masked(frame, keep):
    """``frame`` with the entries outside ``keep`` (H, W) emptied."""
    k = keep.astype(np.float32)
    return replace(frame, rgb=np.asarray(frame.rgb) * k[..., None], alpha=frame.coverage() * k)


@register_pass("stochastic_spreadlets")
class StochasticSpreadletsPass(_Stochastic, SpreadletsPass):
    summary = "spreadlets on a stochastic 1-spp image, each pixel re-centred by its lens sample and time"


@register_pass("stochastic_splat")
class StochasticSplatPass(_Stochastic, SplatPass):
    summary = "dense Splat on a stochastic 1-spp image, each pixel re-centred by its lens sample and time"
    timing_reference = False
