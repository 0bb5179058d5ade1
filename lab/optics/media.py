"""Participating media in Dr.Jit: the Henyey-Greenstein phase function and Woodcock tracking.

Henyey-Greenstein (HG) with anisotropy g in (-1, 1) (g > 0 forward): the density of the cosine
mu between the incoming and the scattered direction is

    p(mu) = (1 - g^2) / (2 (1 + g^2 - 2 g mu)^(3/2)),   mean cosine E[mu] = g.

Sampling inverts its CDF. The textbook form mu = (1 + g^2 - ((1 - g^2) / (1 - g + 2 g u))^2) / (2 g)
divides by g (undefined at g = 0, imprecise near it) and, near |g| = 1, computes 1 - mu ~ 1e-7
as the difference of numbers near 1, which float32 cannot resolve. Expanding it, with
s = 1 - g + 2 g u, gives the exact, division-by-g-free pair

    1 - mu = (1 - g)^2 (1 - u) (1 + g + s) / s^2,     1 + mu = (1 + g)^2 u (1 - g + s) / s^2,

each a product of positive terms (no cancellation), so the forward and the backward peak keep
full relative precision (s itself is computed as (1 - u)(1 - g) + u (1 + g), also without
cancellation): sin(theta) = sqrt((1 - mu)(1 + mu)), and mu comes from the smaller one. At g = 0
it is mu = 2 u - 1 exactly.

Woodcock (delta) tracking samples free-flight distances against a majorant sigma_bar >= sigma_t:
tentative collisions at exponential(sigma_bar) steps, each real with probability
sigma_t / sigma_bar, otherwise a null collision that leaves the direction unchanged. For a
homogeneous medium sigma_bar = sigma_t makes every collision real (plain exponential flights);
a larger majorant gives the same distribution at more steps (the tests use it to check that).
"""
from __future__ import annotations

import math

import drjit as dr
import numpy as np
from drjit.llvm import Array3f, Float, Int32, UInt32

from lab.errors import UserError

__all__ = ["check_g", "hg_pdf", "hg_cdf", "hg_sample", "frame", "unit_circle", "scatter_direction",
           "log_unit", "exp_step", "woodcock_distance"]

# Minimax polynomials of sin and cos on [-pi/4, pi/4] (Cephes sinf/cosf; error < 1e-7 there)
_SIN = (-1.6666654611e-1, 8.3321608736e-3, -1.9515295891e-4)
_COS = (4.166664568298827e-2, -1.388731625493765e-3, 2.443315711809948e-5)
# ln(1 + f) - f + f^2 / 2 = f^3 P(f) on [sqrt(1/2) - 1, sqrt(2) - 1] (Cephes logf), highest power first
_LOG = (7.0376836292e-2, -1.1514610310e-1, 1.1676998740e-1, -1.2420140846e-1, 1.4249322787e-1,
        -1.6668057665e-1, 2.0000714765e-1, -2.4999993993e-1, 3.3333331174e-1)


def check_g(g: float, name: str = "g") -> float:
    """g as a float; UserError unless it lies in the open interval (-1, 1)."""
    if isinstance(g, bool) or not isinstance(g, (int, float)) or not -1.0 < g < 1.0:
        raise UserError(f"{name} = {g!r}: the Henyey-Greenstein anisotropy must lie in (-1, 1) "
                        "(0 isotropic, > 0 forward, < 0 backward; +-1 are delta functions)")
    return float(g)


def hg_pdf(mu, g: float) -> np.ndarray:
    """HG density of mu = cos(theta) on [-1, 1] (numpy, float64); integrates to 1."""
    mu = np.asarray(mu, dtype=np.float64)
    return 0.5 * (1.0 - g * g) / (1.0 + g * g - 2.0 * g * mu) ** 1.5


def hg_cdf(mu, g: float) -> np.ndarray:
    """P(cos(theta) <= mu) for HG (numpy, float64), from integrating :func:`hg_pdf` directly."""
    mu = np.asarray(mu, dtype=np.float64)
    if g == 0.0:
        return 0.5 * (mu + 1.0)
    return (1.0 - g * g) / (2.0 * g) * (1.0 / np.sqrt(1.0 + g * g - 2.0 * g * mu) - 1.0 / (1.0 + g))


def hg_sample(g, u):
    """Sample HG: uniform ``u`` in [0, 1) -> (cos(theta), sin(theta)), stable for all g in (-1, 1).

    ``g`` may be a Python float or a Dr.Jit Float (e.g. opaque); ``u`` a Dr.Jit Float.
    """
    gm, gp, um = 1.0 - g, 1.0 + g, 1.0 - u
    s = um * gm + u * gp                      # = 1 - g + 2 g u, a sum of positive terms
    inv_s2 = dr.rcp(s * s)
    omc = gm * gm * um * (gp + s) * inv_s2    # 1 - mu
    opc = gp * gp * u * (gm + s) * inv_s2     # 1 + mu
    mu = dr.select(omc < opc, 1.0 - omc, opc - 1.0)    # in [-1, 1]: omc, opc >= 0, the smaller < 1
    return mu, dr.sqrt(omc * opc)


def frame(w: Array3f):
    """Two unit vectors completing ``w`` to an orthonormal basis (Duff et al. 2017, branchless)."""
    sign = dr.select(w.z >= 0, 1.0, -1.0)
    a = -1.0 / (sign + w.z)
    b = w.x * w.y * a
    return (Array3f(1.0 + sign * w.x * w.x * a, sign * b, -sign * w.x),
            Array3f(b, sign + w.y * w.y * a, -w.y))


def unit_circle(u):
    """The point at angle 2 pi ``u`` on the unit circle: a uniform azimuth's direction.

    ``dr.sincos`` reduces arbitrary arguments; here 4 u splits into a quarter turn q = round(4 u)
    and a rest x = (4 u - q) pi / 2 in [-pi/4, pi/4] (4 u - q is exact), where short polynomials
    are accurate to float precision (2e-7, against dr.sincos(2 pi u)'s 4e-7); the quarter turns
    swap and negate them.

    Parameters
    ----------
    u : Float
        Fractions of a turn, in [0, 1].

    Returns
    -------
    (Float, Float)
        cos(2 pi u), sin(2 pi u).
    """
    v = 4.0 * u
    q = dr.round(v)
    x = (v - q) * (0.5 * math.pi)
    z = x * x
    sin = dr.fma(x * z, dr.fma(dr.fma(_SIN[2], z, _SIN[1]), z, _SIN[0]), x)
    cos = dr.fma(z * z, dr.fma(dr.fma(_COS[2], z, _COS[1]), z, _COS[0]), dr.fma(-0.5, z, 1.0))
    quarter = Int32(q)
    odd = (quarter & 1) == 1
    c, s = dr.select(odd, sin, cos), dr.select(odd, cos, sin)     # turn by q quarters:
    c = dr.select(((quarter + 1) & 2) == 2, -c, c)                 # q = 1, 2: cos < 0
    s = dr.select((quarter & 2) == 2, -s, s)                       # q = 2, 3: sin < 0
    return c, s


def scatter_direction(w: Array3f, mu, sin, phi_u) -> Array3f:
    """The unit direction at angle acos(mu) from ``w``, azimuth 2 pi ``phi_u`` about it.

    The azimuth is measured in :func:`frame`'s basis (t, b): the direction is mu w + sin v with
    v = cos(phi) t + sin(phi) b, which with Duff's t and b expands to v = (cos(phi) + x A,
    sign sin(phi) + y A, -B), B = sign x cos(phi) + y sin(phi), A = a B (same a and sign):
    fewer multiplications than building t and b.
    """
    cp, sp = unit_circle(phi_u)
    a = -1.0 / (w.z + dr.copysign(1.0, w.z))                # sign = the sign bit of w.z
    big_b = dr.fma(dr.mulsign(w.x, w.z), cp, w.y * sp)
    big_a = a * big_b
    v = Array3f(dr.fma(w.x, big_a, cp), dr.fma(w.y, big_a, dr.mulsign(sp, w.z)), -big_b)
    out = dr.fma(v, sin, w * mu)
    # |out| = 1 up to rounding (~1e-7); one Newton step for 1/|out| keeps it there over any
    # number of scatterings, at less cost than dr.normalize
    return out * dr.fma(dr.squared_norm(out), -0.5, 1.5)


def log_unit(x):
    """The natural logarithm on (0, 1]: ``dr.log`` without its handling of 0, negative, infinite
    and NaN arguments, which a free flight never passes (Cephes logf; within 1 ulp).

    x = m 2^e with m in [sqrt(1/2), sqrt(2)), ln x = e ln 2 + ln m, ln m a polynomial in m - 1;
    ln 2 is split in two parts so e ln 2 adds no rounding error.

    Parameters
    ----------
    x : Float
        Normal floats in (0, 1] (e.g. 1 - u for u uniform on the 2^-24 grid).

    Returns
    -------
    Float
        ln x.
    """
    bits = dr.reinterpret_array(UInt32, x)
    e = Int32(bits >> 23) - 126                                     # x = m 2^e, m in [1/2, 1)
    m = dr.reinterpret_array(Float, (bits & 0x007FFFFF) | 0x3F000000)
    low = m < math.sqrt(0.5)
    e = Float(dr.select(low, e - 1, e))
    f = dr.select(low, m + m, m) - 1.0
    z = f * f
    p = _LOG[0]
    for coeff in _LOG[1:]:
        p = dr.fma(p, f, coeff)
    y = dr.fma(e, -2.12194440e-4, p * f * z)
    return dr.fma(e, 0.693359375, f + dr.fma(z, -0.5, y))


def exp_step(sigma, u):
    """Exponential free flight of rate ``sigma`` (1/m) from uniform ``u`` in [0, 1): -ln(1 - u) / sigma."""
    return -log_unit(1.0 - u) / sigma


def woodcock_distance(sigma_t: float, majorant: float, rng, max_steps: int = 10_000, limit: float = math.inf):
    """Distance to the first real collision by delta tracking, per lane (Dr.Jit loop).

    Parameters
    ----------
    sigma_t : float
        Extinction coefficient (1/m, >= 0).
    majorant : float
        sigma_bar >= sigma_t (1/m, > 0).
    rng : PCG32
        One generator per lane (advanced in place).
    max_steps : int, default 10000
        Tentative collisions per lane at most (a lane still running returns inf).
    limit : float, default inf
        Stop a lane once it passes this distance (it returns its position, > limit).

    Returns
    -------
    Float
        Distance travelled to the first real collision (inf if none within ``max_steps``).
    """
    if not (0.0 <= sigma_t <= majorant and majorant > 0):
        raise UserError(f"woodcock: need 0 <= sigma_t ({sigma_t}) <= majorant ({majorant}) and majorant > 0")
    n = dr.width(rng.state)
    ratio = dr.opaque(Float, sigma_t / majorant)
    sbar = dr.opaque(Float, majorant)
    lim = dr.opaque(Float, limit)

    def cond(t, real, steps, rng):
        return ~real & (steps < max_steps) & (t <= lim)

    def body(t, real, steps, rng):
        t = t + exp_step(sbar, rng.next_float32())
        real = rng.next_float32() < ratio
        return t, real, steps + 1, rng

    t, real, steps, rng = dr.while_loop((dr.zeros(Float, n), dr.zeros(dr.llvm.Bool, n),
                                         dr.zeros(dr.llvm.UInt32, n), rng), cond, body)
    return dr.select(real | (t > lim), t, dr.inf)
