"""PSF models: the registry (by name, like Mitsuba's ``register_integrator``) and the base class.

A model is a class with a frozen config dataclass (``Config``, loadable with
:func:`lab.config.from_table` from a scene's ``[psf.<name>]`` table) that states its PSF space
(a :class:`NestedGrid`: ranges, beta, sample count), its symmetries and channels, and supplies the
per-ray Dr.Jit function the light tracer runs. ``trace(cell, n_rays, seed)`` returns the cell's
pre-filtered PSF.
"""
from __future__ import annotations

import abc
from functools import cached_property
from typing import ClassVar

import numpy as np

from lab.config import from_table
from lab.errors import UserError
from runtime_cl.registry import Registry
from lab.psf_tracing.space import Box, NestedGrid, boxes
from lab.psf_tracing.tracer import RayHits, TraceResult, trace_psf

__all__ = ["PSFModel", "register_model", "get_model", "model_names", "load_model"]

_MODELS = Registry("PSF model")
register_model = _MODELS.register
model_names = _MODELS.names
get_model = _MODELS.get


def load_model(name: str, table: dict, where: str | None = None) -> "PSFModel":
    """Build model ``name`` from its TOML table (e.g. a scene's ``[psf.simple_lens]``).

    ``where`` names the file and table in error messages (default ``[psf.<name>]``).
    """
    cls = get_model(name)
    return cls(from_table(cls.Config, table, where or f"[psf.{name}]"))


class PSFModel(abc.ABC):
    """A family of PSFs over a low-dimensional PSF space (LSR18 section 5.1).

    Class attributes: ``name`` (set by :func:`register_model`), ``Config`` (frozen dataclass),
    ``symmetries`` (e.g. ``("rotation",)``: dimensions the space omits), ``channels`` (1 or 3).
    The config must provide ``seed``, ``rays_per_psf``, ``rays_per_launch`` and ``psf_resolution``.
    """

    name: ClassVar[str]
    Config: ClassVar[type]
    symmetries: ClassVar[tuple[str, ...]] = ()
    channels: ClassVar[int] = 1
    # the sparsifier's denoising level for this model's traced PSFs (None: lab.sparsify.noise.TAU)
    denoise_tau: ClassVar[float | None] = None

    def __init__(self, config):
        if not isinstance(config, self.Config):
            raise TypeError(f"{type(self).__name__} needs a {self.Config.__name__}, got {type(config).__name__}")
        self.config = config

    # --- the PSF space ---------------------------------------------------------------------
    @property
    @abc.abstractmethod
    def grid(self) -> NestedGrid:
        """The sampled PSF space (ranges, beta, nested grid)."""

    @property
    def beta(self) -> tuple:
        """Power-remapping exponent per dimension (LSR18 Tbl. 1)."""
        return self.grid.beta

    @property
    def resolution(self) -> int:
        """R: PSF images are R x R pixels."""
        return self.config.psf_resolution

    @cached_property
    def boxes(self) -> list[Box]:
        """Each cell's box in physical coordinates (the pre-filter support), in index order."""
        return boxes(self.grid)

    # --- tracing -----------------------------------------------------------------------------
    @abc.abstractmethod
    def rays(self, coords: list, rng) -> RayHits:
        """Per-ray Dr.Jit function: PSF coordinates (one Float per dimension) -> landing points."""

    def trace_box(self, lo, hi, n_rays: int | None = None, seed: int | None = None,
                  stream: int = 0) -> TraceResult:
        """Trace the PSF pre-filtered over the box [lo, hi] (physical coordinates).

        ``n_rays`` and ``seed`` default to the config's ``rays_per_psf`` and ``seed``.
        """
        cfg = self.config
        return trace_psf(self.rays, lo, hi, self.resolution,
                         cfg.rays_per_psf if n_rays is None else n_rays,
                         cfg.seed if seed is None else seed,
                         channels=self.channels, stream=stream, rays_per_launch=cfg.rays_per_launch)

    def trace_cell(self, cell: int, n_rays: int | None = None, seed: int | None = None) -> TraceResult:
        """Trace cell ``cell`` of :attr:`grid` pre-filtered over its box; result with statistics."""
        if isinstance(cell, bool) or not isinstance(cell, (int, np.integer)) or not 0 <= cell < self.grid.size:
            raise UserError(f"cell = {cell!r}: must be an integer in 0..{self.grid.size - 1}")
        b = self.boxes[int(cell)]
        n = self.rays_for_cell(int(cell)) if n_rays is None else n_rays
        return self.trace_box(b.lo, b.hi, n, seed, stream=int(cell))

    def rays_for_cell(self, cell: int) -> int:
        """Rays traced for ``cell`` by default: the config's ``rays_per_psf``.

        Models whose PSFs grow with the coordinate override this to keep the Monte Carlo noise per
        PSF pixel (which the Laplacian amplifies, LSR18 section 5.3) the same for every cell.
        """
        return self.config.rays_per_psf

    def trace_checked(self, cell: int, n_rays: int | None = None, seed: int | None = None) -> TraceResult:
        """:meth:`trace_cell`, raising UserError if any ray landed outside the PSF image
        (the config's resolution is too small for its range)."""
        result = self.trace_cell(cell, n_rays, seed)
        if result.n_outside:
            raise UserError(f"PSF model {self.name}: {result.n_outside} of {result.n_rays} rays of cell "
                            f"{cell} landed outside the {self.resolution}^2 PSF image; raise psf_resolution")
        return result

    # --- what the sparsifier stores --------------------------------------------------------
    @property
    def basis(self) -> str:
        """What the database stores (:mod:`runtime_cl.psf.database`): ``"rows"``, ``"laplacian"``
        or ``"dual"`` (both). The config's ``basis`` key, else LSR18's Laplacian (models whose
        PSFs turn by any angle: row differences can only be drawn as stored or half-turned)."""
        return getattr(self.config, "basis", "laplacian")

    @property
    def fitted_bases(self) -> tuple:
        """The bases :func:`lab.sparsify.spreadlets.sparsify` fits to every cell: :attr:`basis`, or
        for ``"dual"`` the Laplacian and then the row differences."""
        return ("laplacian", "rows") if self.basis == "dual" else (self.basis,)

    def fingerprint(self) -> dict:
        """What a labelled image's ``splatlab.camera`` header must say for this model's database to
        match it: header key -> the value traced (checked by :func:`runtime_cl.psf.fingerprint.
        check_header` before a render). Default: no medium (a lens model's PSFs carry no fog, so
        an input that asks for one needs a volume database) and the aperture, for models with
        aperture keys."""
        aperture = getattr(self.config, "header_aperture", None)
        return {"medium": None} | ({"aperture": aperture()} if aperture is not None else {})

    def energy(self, traced: TraceResult) -> np.ndarray | None:
        """Per channel, the light of a traced PSF that reaches the image, relative to the point as
        it would be seen without losses; None (the default) for models whose PSFs are normalised
        (lenses: every ray through the optics lands, vignetting as the reference renormalises).

        A model whose losses are part of the effect (a medium's absorption and out-scattering)
        returns them here; the database then stores ``psf * energy`` (:func:`lab.precompute.cell.
        build_cell`), so a render darkens as its reference does.
        """
        return None

    def trace(self, cell: int, n_rays: int | None = None, seed: int | None = None) -> np.ndarray:
        """The pre-filtered PSF of ``cell`` as the runtime draws it: (R, R, C) float32, each channel
        summing to its :meth:`energy` (1 for a normalised model).

        Centre at pixel (R//2, R//2), rows = y downward (see :meth:`trace_checked`, whose PSF is
        always normalised per channel).
        """
        traced = self.trace_checked(cell, n_rays, seed)
        energy = self.energy(traced)
        return traced.psf if energy is None else (traced.psf * np.asarray(energy, np.float32)).astype(np.float32)
