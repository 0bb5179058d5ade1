"""Optical glass from Sellmeier coefficients (LES10 section 4), a small catalog by name.

The Sellmeier equation gives the refractive index at vacuum wavelength lambda (micrometres):

    n(lambda)^2 = 1 + sum_i B_i lambda^2 / (lambda^2 - C_i),   i = 1..3,

with the B_i dimensionless and the C_i in square micrometres. The catalog holds the coefficients
Schott publishes in its optical glass data sheets (N-BK7: the borosilicate crown LES10 uses;
F2, N-SF10 and N-SF11: flints of rising index and dispersion) and ``"air"``, taken as exactly 1 (pbrt-v4's
convention; real air, n = 1.00027, would shift every focus by the same tiny amount).

Each entry also records the data sheet's n_d (587.56 nm) and Abbe number v_d, so the tests check
the coefficients against independently published figures.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from lab.errors import UserError

__all__ = ["Glass", "GLASSES", "AIR", "glass_names", "get_glass", "LINE_D_NM", "LINE_F_NM",
           "LINE_C_NM", "abbe_number"]

# Fraunhofer lines used for n_d and the Abbe number v_d = (n_d - 1) / (n_F - n_C), in nm.
LINE_D_NM = 587.5618   # helium d line
LINE_F_NM = 486.1327   # hydrogen F line
LINE_C_NM = 656.2725   # hydrogen C line

# The Sellmeier equation is fitted over about 0.3 .. 2.5 micrometres; outside it is not glass.
_MIN_NM, _MAX_NM = 300.0, 2500.0


@dataclass(frozen=True)
class Glass:
    """A glass (or air) with Sellmeier coefficients.

    Parameters
    ----------
    name : str
        Catalog name, e.g. ``"N-BK7"``.
    b : tuple of 3 float
        Sellmeier B_1..B_3 (dimensionless); all 0 for air.
    c : tuple of 3 float
        Sellmeier C_1..C_3 in square micrometres.
    nd, vd : float
        The data sheet's index at 587.56 nm and Abbe number (for checks and reports; 1 and inf
        for air).
    """

    name: str
    b: tuple
    c: tuple
    nd: float
    vd: float

    def index(self, wavelength_nm) -> np.ndarray | float:
        """Refractive index at vacuum wavelength(s) ``wavelength_nm`` (nanometres, 300..2500).

        Returns a float for a scalar argument, else a float64 array.
        """
        lam = np.asarray(wavelength_nm, dtype=np.float64)
        if not np.all(np.isfinite(lam)) or np.any((lam < _MIN_NM) | (lam > _MAX_NM)):
            raise UserError(f"wavelength_nm = {wavelength_nm!r}: the Sellmeier fit of {self.name} holds "
                            f"for {_MIN_NM:.0f} .. {_MAX_NM:.0f} nm; use a wavelength in that range")
        l2 = (lam / 1000.0) ** 2
        n2 = 1.0 + sum(bi * l2 / (l2 - ci) for bi, ci in zip(self.b, self.c))
        n = np.sqrt(n2)
        return float(n) if n.ndim == 0 else n

    @property
    def is_air(self) -> bool:
        return not any(self.b)


def abbe_number(glass: Glass) -> float:
    """v_d = (n_d - 1) / (n_F - n_C) from the Sellmeier coefficients (inf for air)."""
    dn = glass.index(LINE_F_NM) - glass.index(LINE_C_NM)
    return math.inf if dn == 0 else (glass.index(LINE_D_NM) - 1.0) / dn


AIR = Glass("air", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 1.0, math.inf)

# Schott optical glass data sheets (coefficients, n_d and v_d as published).
GLASSES: dict[str, Glass] = {g.name: g for g in (
    AIR,
    Glass("N-BK7", (1.03961212, 0.231792344, 1.01046945),
          (0.00600069867, 0.0200179144, 103.560653), 1.51680, 64.17),
    Glass("F2", (1.34533359, 0.209073176, 0.937357162),
          (0.00997743871, 0.0470450767, 111.886764), 1.62004, 36.37),
    Glass("N-SF10", (1.62153902, 0.256287842, 1.64447552),
          (0.0122241457, 0.0595736775, 147.468793), 1.72828, 28.53),
    Glass("N-SF11", (1.73759695, 0.313747346, 1.89878101),
          (0.013188707, 0.0623068142, 155.23629), 1.78472, 25.68),
)}


def glass_names() -> list[str]:
    """Names in the catalog, sorted."""
    return sorted(GLASSES)


def get_glass(name: str) -> Glass:
    """The catalog glass ``name``; UserError listing the catalog otherwise."""
    try:
        return GLASSES[name]
    except (KeyError, TypeError):
        raise UserError(f"glass = {name!r} is not in the catalog; known glasses are {glass_names()} "
                        "(add its Sellmeier coefficients to lab/optics/glass.py)") from None
