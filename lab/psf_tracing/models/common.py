"""Config pieces shared by the PSF models: aperture keys, the canonical thin lens, value checks.

The key groups are keyword-only dataclass mixins; a model's frozen config inherits them, so a
scene's ``[psf.<model>]`` table has the same ``aperture*`` and ``lens_*`` keys for every model
that uses them, validated in one place.

Symmetry tags a model lists in ``symmetries`` (recorded in the spreadlet database) and what a
runtime must do with them:

``"rotation"``
    The PSF is rotation invariant: no angle dimension, draw it as stored.
``"coc_sign"``
    The PSF space holds |CoC|; stored PSFs are those of points in front of the focal plane
    (signed CoC < 0, the aperture rotated by 180 degrees). A point behind the focal plane
    (CoC > 0) is drawn with the stored PSF rotated by 180 degrees about its centre.
``"motion_direction"``
    Traced for motion along the config's ``motion_direction_deg``; a pixel moving at angle
    phi (counter-clockwise from image +x, y up) is drawn with the PSF rotated by
    phi - motion_direction_deg (plus 180 degrees if ``"coc_sign"`` applies and CoC > 0).
``"motion_angle"``
    A shaped aperture's motion: the PSF space's last coordinate is the motion direction in
    degrees modulo the aperture's turn period, a uniform coordinate whose bins are centred on
    multiples of their width. A pixel moving at phi takes the bin of phi modulo the period and
    is drawn turned by phi minus the bin's centre (plus 180 degrees as ``"coc_sign"`` says).
``"optical_axis"``
    The optics are rotation symmetric about the optical axis, but the PSF varies across the
    image: only pixels on the image's +x side of the centre are traced (reference direction 0),
    indexed by their distance from the centre (eccentricity). A pixel at azimuth phi about the
    image centre (counter-clockwise from image +x, y up) is drawn with the PSF rotated by phi.
``"stop_turn"``
    With ``"optical_axis"``, a shaped stop: the PSF space's last coordinate is the pixel's
    azimuth phi in degrees modulo the stop's turn period (uniform bins centred on multiples of
    their width), traced as the point at azimuth 0 seen through the stop turned by -phi; the
    pixel is drawn turned by phi, as ``"optical_axis"`` says.

Rotations turn the PSF counter-clockwise as the image is viewed; the runtime
(:mod:`runtime_cl.coords.maps`, ``Renderer.render(angle=...)``) takes the angle in radians.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from lab.errors import UserError
from lab.optics.aperture import Aperture, get_aperture, make_aperture
from lab.optics.thin_lens import ThinLens
from lab.psf_tracing.tracer import MAX_RAYS_PER_LAUNCH
from runtime_cl.psf.grid import MAX_BINS, MAX_SAMPLES, NestedGrid

__all__ = ["ApertureKeys", "BasisKeys", "LensKeys", "check_number", "check_common", "whole_launches",
           "SYMMETRY_TAGS", "check_angle_bins", "binned_grid"]

SYMMETRY_TAGS = ("rotation", "coc_sign", "motion_direction", "motion_angle", "optical_axis", "stop_turn")
DEFAULT_BIN_DEG = 10.0   # widest default angle bin of a shaped aperture

# config key -> the aperture class's parameter
_APERTURE_PARAMS = {"aperture_blades": "blades", "aperture_rotation_deg": "rotation_deg",
                    "aperture_rounding": "rounding", "aperture_image": "path",
                    "aperture_image_sha256": "sha256"}


# Upper bounds of a model's counts and sizes, and why (a typo of a few digits must not hang or
# exhaust memory hours into a job).
SIZE_BOUNDS = {
    "samples": (MAX_SAMPLES, "each sample is a traced PSF and a database row; LSR18 uses hundreds"),
    "psf_resolution": (16383, "a PSF is traced into psf_resolution^2 float32 pixels, 1 GB at 16383, and "
                              "its offsets are stored in 16 bits"),
    "rays_per_psf": (1 << 40, "2^40 rays take about an hour per PSF at 300 M rays/s"),
    "rays_per_pixel": (1 << 24, "sparsifying converges long before"),
    "width_px": (16384, "the largest scene resolution"),
    "lens_width_px": (16384, "the largest scene resolution"),
    "max_collisions": (1 << 16, "a walk this long carries no light"),
}


def check_number(name: str, value, *, integer: bool = False, zero_ok: bool = False) -> None:
    """UserError unless ``value`` is a finite number (an integer if ``integer``) > 0 (>= 0 if
    ``zero_ok``) and at most its bound in :data:`SIZE_BOUNDS` (the message says why)."""
    kinds = (int,) if integer else (int, float)
    ok = (isinstance(value, kinds) and not isinstance(value, bool)
          and (isinstance(value, int) or math.isfinite(value)) and (value >= 0 if zero_ok else value > 0))
    if not ok:
        what = "an integer" if integer else "a finite number"
        raise UserError(f"{name} = {value!r}: must be {what} {'>= 0' if zero_ok else '> 0'}")
    if name in SIZE_BOUNDS and value > SIZE_BOUNDS[name][0]:
        bound, why = SIZE_BOUNDS[name]
        raise UserError(f"{name} = {value!r}: at most {bound} ({why})")


def check_common(cfg) -> None:
    """The keys every traced model has: samples, psf_resolution, ray counts, density, seed."""
    check_number("density", cfg.density)
    for name in ("samples", "psf_resolution", "rays_per_psf", "rays_per_pixel", "rays_per_launch"):
        check_number(name, getattr(cfg, name), integer=True)
    check_number("seed", cfg.seed, integer=True, zero_ok=True)
    if cfg.rays_per_launch > MAX_RAYS_PER_LAUNCH:
        raise UserError(f"rays_per_launch = {cfg.rays_per_launch}: at most {MAX_RAYS_PER_LAUNCH}")


def check_angle_bins(cfg, period_deg: float) -> None:
    """A config's ``angle_bins`` for an aperture of turn period ``period_deg``: none for a shape
    that looks the same at every turn (period 0), else by default bins of at most 10 degrees,
    an integer in [1, MAX_BINS] with samples x angle_bins traced PSFs at most MAX_SAMPLES."""
    if period_deg == 0.0:
        if cfg.angle_bins is not None:
            raise UserError(f"angle_bins = {cfg.angle_bins!r}: a round aperture looks the same at every turn; "
                            "remove the key")
        return
    if cfg.angle_bins is None:
        object.__setattr__(cfg, "angle_bins", math.ceil(period_deg / DEFAULT_BIN_DEG - 1e-9))
    check_number("angle_bins", cfg.angle_bins, integer=True)
    if cfg.angle_bins > MAX_BINS or cfg.samples * cfg.angle_bins > MAX_SAMPLES:
        raise UserError(f"angle_bins = {cfg.angle_bins}: at most {MAX_BINS}, and samples x angle_bins at most "
                        f"{MAX_SAMPLES} (each is a traced PSF); use fewer")


def binned_grid(samples: int, beta, ranges, names, bins: int, period_deg: float, name: str) -> NestedGrid:
    """The nested grid of ``samples`` cells per bin, plus the uniform angle ``name`` in ``bins``
    bins of one turn period, centred on 0, w, 2w, ... (w = period / bins); without bins the
    nested grid alone."""
    if not bins:
        return NestedGrid.for_samples(samples, beta, ranges, names)
    half = 0.5 * period_deg / bins
    return NestedGrid.for_samples(samples * bins, tuple(beta) + (1.0,), tuple(ranges) + ((-half, period_deg - half),),
                                  tuple(names) + (name,), bins=bins)


def whole_launches(n: int, rays_per_launch: int) -> int:
    """``n`` rounded up to a whole number of launches."""
    return -(-int(n) // rays_per_launch) * rays_per_launch


@dataclass(frozen=True, kw_only=True)
class ApertureKeys:
    """Aperture keys of a model's config.

    Parameters
    ----------
    aperture : str, default "circle"
        Shape name (:func:`lab.optics.aperture.aperture_names`): circle, polygon, star, heart, image.
    aperture_blades : int, optional
        ``polygon`` only: blade count, >= 3 (default 6).
    aperture_rotation_deg : float, optional
        ``polygon`` only: counter-clockwise rotation in degrees (default 0: a corner up).
    aperture_rounding : float, optional
        ``polygon`` only: corner fillet radius as a fraction of the circumradius, in [0, 1]
        (default 0 sharp; 1 is a circle).
    aperture_image : str, optional
        ``image`` only (required there): path of a PNG, bright = open.
    aperture_image_sha256 : str, optional
        ``image`` only: the file's SHA-256. Filled in from the file when omitted, so the
        configuration (and its content hash) changes when the image does; when given, the file
        must match it.
    """

    aperture: str = "circle"
    aperture_blades: int | None = None
    aperture_rotation_deg: float | None = None
    aperture_rounding: float | None = None
    aperture_image: str | None = None
    aperture_image_sha256: str | None = None

    def header_aperture(self):
        """The aperture as a ``splatlab.camera`` header states it: None for the circle (the header
        has no ``aperture``), the iris ``{blades, rotation_deg, rounding}`` for a polygon, else
        ``{"shape": name}`` (and the image's ``sha256``)."""
        if self.aperture == "circle":
            return None
        if self.aperture == "polygon":
            return {"blades": self.aperture_blades or 6, "rotation_deg": float(self.aperture_rotation_deg or 0.0),
                    "rounding": float(self.aperture_rounding or 0.0)}
        shape = {"shape": self.aperture}
        return shape if self.aperture_image_sha256 is None else dict(shape, sha256=self.aperture_image_sha256)

    def _aperture_params(self) -> dict:
        cls = get_aperture(self.aperture)
        takes = {f.name for f in dataclasses.fields(cls)} if dataclasses.is_dataclass(cls) else set()
        given = {k: getattr(self, k) for k in _APERTURE_PARAMS if getattr(self, k) is not None}
        extra = sorted(k for k in given if _APERTURE_PARAMS[k] not in takes)
        if extra:
            fits = sorted(k for k, p in _APERTURE_PARAMS.items() if p in takes)
            raise UserError(f"aperture = {self.aperture!r} does not use {extra}; remove them "
                            f"(its keys: {fits or 'none'})")
        if "path" in takes and "aperture_image" not in given:
            raise UserError(f"aperture = {self.aperture!r} needs aperture_image = 'path/to/shape.png'")
        return {_APERTURE_PARAMS[k]: v for k, v in given.items()}

    def build_aperture(self) -> Aperture:
        """The configured aperture (reads an image file once per call)."""
        return make_aperture(self.aperture, **self._aperture_params())

    def check_aperture(self) -> Aperture:
        """Validate the aperture keys (in ``__post_init__``); record an image's digest."""
        ap = self.build_aperture()
        digest = getattr(ap, "digest", None)
        if digest is not None and self.aperture_image_sha256 is None:
            object.__setattr__(self, "aperture_image_sha256", digest)
        return ap


@dataclass(frozen=True, kw_only=True)
class LensKeys:
    """The canonical thin lens that makes a traced path physical (the PSFs in CoC space do not
    depend on it beyond float rounding).

    Parameters
    ----------
    lens_focal_length_mm : float, default 50
    lens_f_number : float, default 2
    lens_focus_distance_m : float, default 2
    lens_sensor_width_mm : float, default 36
    lens_width_px : int, default 1920
        Image width in pixels across the sensor (sets the pixel size).
    """

    lens_focal_length_mm: float = 50.0
    lens_f_number: float = 2.0
    lens_focus_distance_m: float = 2.0
    lens_sensor_width_mm: float = 36.0
    lens_width_px: int = 1920

    @property
    def lens(self) -> ThinLens:
        """The canonical thin lens."""
        return ThinLens(focal_length_mm=self.lens_focal_length_mm, f_number=self.lens_f_number,
                        focus_distance_m=self.lens_focus_distance_m,
                        sensor_width_mm=self.lens_sensor_width_mm)

    def check_lens(self) -> None:
        check_number("lens_width_px", self.lens_width_px, integer=True)
        try:
            self.lens
        except UserError as exc:
            raise UserError(f"canonical lens (lens_* keys): {exc}") from None


@dataclass(frozen=True, kw_only=True)
class BasisKeys:
    """What the sparsifier stores, for models whose PSFs are drawn as stored or half-turned.

    Parameters
    ----------
    basis : {"rows", "laplacian"}, default "rows"
        Row differences (:mod:`lab.sparsify.rows`: half the terms of LSR18's Laplacian
        spreadlets or fewer at a higher SSIM, no dense fast track for PSFs 3 px wide and more,
        summed along rows as they are merged instead of a Poisson solve), or LSR18's Laplacian
        spreadlets.
    """

    basis: str = "rows"

    def check_basis(self) -> None:
        if self.basis not in ("laplacian", "rows"):
            raise UserError(f"basis = {self.basis!r}: choose one of ['laplacian', 'rows']")
