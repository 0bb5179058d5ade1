"""Settings of the Volume model (a scene's ``[psf.volume]`` table), validated before any tracing."""
from __future__ import annotations

from dataclasses import dataclass

from lab.errors import UserError
from lab.optics.media import check_g
from lab.psf_tracing.models.common import check_number
from lab.psf_tracing.tracer import MAX_RAYS_PER_LAUNCH

__all__ = ["VolumeConfig"]


@dataclass(frozen=True)
class VolumeConfig:
    """Settings of the Volume model.

    Parameters
    ----------
    max_distance_m : float, default 5.0
        Largest light-camera distance of the database, metres (> min_distance_m).
    min_distance_m : float, default 0.0
        Smallest distance, metres (>= 0).
    medium_density : float, default 0.9
        Extinction coefficient sigma_t of the medium in 1/m (>= 0; LSR18's "density" .9).
    g : float, default 0.8
        Henyey-Greenstein anisotropy in (-1, 1) (LSR18: .8, forward scattering).
    albedo : (float, float, float), default (1.0, 1.0, 0.9)
        Single-scattering albedo of the R, G, B channels, each in [0, 1] (LSR18).
    majorant_ratio : float, default 1.0
        Woodcock majorant sigma_bar / sigma_t (>= 1). 1 is exact and fastest for a homogeneous
        medium; larger values add null collisions (same result, for testing the tracker).
    escape_mfp : float, default 10.0
        A photon is dropped once farther than d + escape_mfp / sigma_t from the light (> 0).
    max_collisions : int, default 1000
        Tentative collisions per photon at most (>= 1).
    roulette_mfp : float, default 0.5
        Russian roulette away from the camera sphere: a photon path that first passes the radius
        d + (2^k - 1) * roulette_mfp / sigma_t (k = 1 .. 12) survives with probability 1/2 and
        counts twice from then on (unbiased; 0: off). It ends walks far from the camera early.
    focal_length_mm, sensor_width_mm : float, default 50, 36
        The camera's pinhole (focal length and sensor width in mm).
    width_px : int, default 1024
        Image width in pixels across the sensor: the focal length in pixels is
        focal_length_mm * width_px / sensor_width_mm.
    samples : int, default 200
        Minimum number of PSF samples (LSR18: 200).
    beta : float, default 1.0
        Power-remapping exponent of the distance (LSR18: 1.0).
    psf_resolution : int, default 255
        R, the PSF image edge in pixels (at most 65535); the halo beyond it is cut off.
    rays_per_psf : int, default 2**23
        Photons traced per PSF.
    rays_per_launch : int, default 2**22
        Photons per Dr.Jit launch (1 .. 2**30), bounding memory.
    density : float, default 1.0
        Relative spreadlet density for the sparsifier (> 0); not the medium's (see
        ``medium_density``).
    seed : int, default 0
        Random seed (>= 0); same seed, same PSFs bitwise.
    """

    max_distance_m: float = 5.0
    min_distance_m: float = 0.0
    medium_density: float = 0.9
    g: float = 0.8
    albedo: tuple[float, float, float] = (1.0, 1.0, 0.9)
    majorant_ratio: float = 1.0
    escape_mfp: float = 10.0
    max_collisions: int = 1000
    roulette_mfp: float = 0.5
    focal_length_mm: float = 50.0
    sensor_width_mm: float = 36.0
    width_px: int = 1024
    samples: int = 200
    beta: float = 1.0
    psf_resolution: int = 255
    rays_per_psf: int = 2 ** 23
    rays_per_launch: int = 2 ** 22
    density: float = 1.0
    seed: int = 0

    def __post_init__(self):
        check_number("medium_density", self.medium_density, zero_ok=True)
        check_g(self.g)
        check_number("min_distance_m", self.min_distance_m, zero_ok=True)
        check_number("max_distance_m", self.max_distance_m)
        if self.max_distance_m <= self.min_distance_m:
            raise UserError(f"min_distance_m = {self.min_distance_m}, max_distance_m = {self.max_distance_m}: "
                            "need min_distance_m < max_distance_m")
        if len(self.albedo) != 3 or not all(isinstance(a, (int, float)) and not isinstance(a, bool)
                                            and 0.0 <= a <= 1.0 for a in self.albedo):
            raise UserError(f"albedo = {self.albedo!r}: give three values in [0, 1], for R, G and B")
        check_number("majorant_ratio", self.majorant_ratio)
        if self.majorant_ratio < 1.0:
            raise UserError(f"majorant_ratio = {self.majorant_ratio}: Woodcock tracking needs a majorant "
                            ">= sigma_t; use a value >= 1")
        if self.medium_density == 0.0:
            raise UserError("medium_density = 0: without a medium the PSF is a delta; use simple_lens, "
                            "or a density > 0 (1/m)")
        for name in ("escape_mfp", "focal_length_mm", "sensor_width_mm", "beta", "density"):
            check_number(name, getattr(self, name))
        for name in ("max_collisions", "width_px", "samples", "psf_resolution", "rays_per_psf",
                     "rays_per_launch"):
            check_number(name, getattr(self, name), integer=True)
        check_number("seed", self.seed, integer=True, zero_ok=True)
        check_number("roulette_mfp", self.roulette_mfp, zero_ok=True)
        if self.psf_resolution > 65535:
            raise UserError(f"psf_resolution = {self.psf_resolution}: at most 65535 (pixel offsets are "
                            "stored in 16 bits)")
        if self.rays_per_launch > MAX_RAYS_PER_LAUNCH:
            raise UserError(f"rays_per_launch = {self.rays_per_launch}: at most {MAX_RAYS_PER_LAUNCH}")

    @property
    def focal_length_px(self) -> float:
        """The pinhole's focal length in pixels."""
        return self.focal_length_mm * self.width_px / self.sensor_width_mm
