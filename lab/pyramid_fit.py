"""Fit the convolution pyramid's kernels (``python -m lab.pyramid_fit``): writes
``runtime_cl/integrate/pyramid_kernels.json``, which :mod:`runtime_cl.integrate.pyramid_model`
reads.

What is fitted: the operator of :mod:`runtime_cl.integrate.pyramid_model` should map the 5-point
Laplacian of any image that is zero on its border ring back to the image, i.e. act as convolution
with the free-space Green's function of the 5-point Laplacian (which is what the exact FFT solve
computes on such canvases). The training set is such images: sums of soft-edged discs of
log-uniform radii from 1 px to a sixth of the canvas and exponential intensities, blurred or not
(PSF-like), and whole bright frames with a zero border (:func:`frame_image`), on canvases of
128^2 to 256^2 (:func:`training_set`); the truth is the image itself.

How (variable projection): the output is linear in the ``g`` kernels' values once ``h1`` and
``h2`` are fixed. For given taps, each basis kernel of each ``g`` (one per fine level, one shared
by the coarser levels; :func:`runtime_cl.integrate.pyramid_model.symmetric_basis`) is pushed
through the pyramid alone, giving one column per value; the ``g`` values minimise the 8-norm
of the columns' combination minus the images (iteratively reweighted least squares), every
pixel's error relative to its image's largest value (the error the benchmark reports; the
8-norm stands in for the largest error, which the targets bound, while keeping the mean in
view). ``scipy.optimize.minimize`` (Nelder-Mead) searches the taps of ``h1`` (centre fixed at
1: its scale trades with ``g``'s) and ``h2`` on that norm.

The shipped kernels (``pyramid_kernels.json``, its ``fit`` record says which run): the taps of
``--radii 2 1 1 --evaluations 150`` (started from a 3x3 fit's, before the bright frames joined
the training set), then ``--radii 2 3 3 --evaluations 0`` on those taps (7x7 ``g`` above the finest level roughly halves the largest
error; searching the taps again at that size was too slow to finish, ~20 s per evaluation).
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from runtime_cl.atomic_file import atomic_path
from runtime_cl.integrate.pyramid_model import (FORMAT, KERNELS_FILE, PAD, TOP, PyramidKernels, analysis,
                                                correlate2, ring_mean, symmetric_basis, symmetric_kernel,
                                                upsample)
from runtime_cl.integrate.poisson import laplacian5

__all__ = ["disc_image", "training_set", "basis_columns", "fit", "relative_errors", "main"]


def disc_image(n: int, rng, discs: int, r_max: float | None = None, blur: float = 0.0) -> np.ndarray:
    """(n, n) sum of ``discs`` soft-edged (1 px rim) discs, radii log-uniform in [1, r_max]
    (default n / 6), exponential intensities, optionally Gaussian-blurred by ``blur`` px; zero on
    a border ring of ``r_max`` + 2 px (so the image is exactly recoverable from its Laplacian)."""
    r_max = r_max or n / 6
    border = int(r_max + 3 * blur) + 2
    y, x = np.mgrid[0:n, 0:n] + 0.5
    f = np.zeros((n, n))
    for _ in range(discs):
        r = float(np.exp(rng.uniform(0.0, np.log(r_max))))
        lo, hi = border + r, n - border - r
        cx, cy = rng.uniform(lo, hi, 2) if hi > lo else (n / 2, n / 2)
        f += rng.exponential(1.0) * np.clip(r + 0.5 - np.hypot(x - cx, y - cy), 0.0, 1.0)
    if blur > 0:
        from scipy.ndimage import gaussian_filter

        f = gaussian_filter(f, blur, mode="constant")
    f[0] = f[-1] = f[:, 0] = f[:, -1] = 0.0
    return f


def training_set(seed: int) -> list[np.ndarray]:
    """The images the kernels are fitted on (``seed`` 1) or checked on (another seed): sharp
    discs (:func:`disc_image`), PSF sums with soft rims
    (:func:`runtime_cl.psf.synthetic.psf_sum_image`) and bright frames (:func:`frame_image`),
    128^2 to 256^2, one channel."""
    from runtime_cl.psf.synthetic import psf_sum_image

    rng = np.random.default_rng(seed)
    sharp = [disc_image(n, rng, k) for n, k in ((128, 10), (192, 20), (256, 30), (256, 8))]
    soft = [psf_sum_image(n, seed * 1000 + n, channels=1)[..., 0].astype(np.float64) for n in (128, 192, 256)]
    return sharp + soft + [frame_image(n, rng) for n in (160, 256)]


def frame_image(n: int, rng) -> np.ndarray:
    """A whole bright frame inside a zero border (a rendered image on its padded canvas): a
    smooth random field over ~n - 2 n / 10 px with a soft 4 px edge, plus a few discs. Without
    it the fit never sees features at the canvas's own scale (the coarsest levels)."""
    b = n // 10
    yy, xx = np.mgrid[0:n, 0:n] + 0.5
    edge = np.clip(np.minimum.reduce([xx - b, yy - b, n - b - xx, n - b - yy]) / 4.0, 0.0, 1.0)
    lattice = rng.random((5, 5))
    y = np.linspace(0, 4, n, endpoint=False)[:, None]
    x = np.linspace(0, 4, n, endpoint=False)[None, :]
    y0, x0 = y.astype(int), x.astype(int)
    fy, fx = y - y0, x - x0
    field = ((1 - fy) * (1 - fx) * lattice[y0, x0] + (1 - fy) * fx * lattice[y0, x0 + 1]
             + fy * (1 - fx) * lattice[y0 + 1, x0] + fy * fx * lattice[y0 + 1, x0 + 1])
    f = (0.3 + 0.7 * field) * edge + disc_image(n, rng, 6, r_max=n / 12)
    f[0] = f[-1] = f[:, 0] = f[:, -1] = 0.0
    return f


def basis_columns(lap: np.ndarray, h1, h2, radii) -> np.ndarray:
    """(pixels, values): the pyramid's output for each basis kernel of each ``g`` alone, border
    ring mean removed. ``g`` number ``k`` (of radius ``radii[k]``) serves level ``k``, the last
    one every level from ``len(radii) - 1`` on."""
    a = analysis(lap - lap.mean(), h1)
    own_levels = len(radii) - 1
    cols = []
    for group in range(own_levels + 1):
        levels = [group] if group < own_levels else list(range(own_levels, len(a)))
        for b in symmetric_basis(radii[group]):
            s = None
            for level in range(len(a) - 1, -1, -1):
                if s is not None:
                    s = upsample(s, h2, a[level].shape)
                if level in levels:
                    term = correlate2(a[level], b)
                    s = term if s is None else s + term
            cols.append((s - ring_mean(s)).ravel())
    return np.stack(cols, axis=1)


def _taps(p, n_taps: int):
    r = n_taps // 2
    h1 = np.r_[p[:r], 1.0, p[:r][::-1]]
    h2 = np.r_[p[r:2 * r], p[2 * r], p[r:2 * r][::-1]]
    return h1, h2


def _system(p, images, n_taps, radii):
    h1, h2 = _taps(p, n_taps)
    rows, rhs = [], []
    for f in images:
        s = 1.0 / np.abs(f).max()
        rows.append(basis_columns(laplacian5(f), h1, h2, radii) * s)
        rhs.append(f.ravel() * s)
    return np.concatenate(rows), np.concatenate(rhs)


def _solve(A, b, power: float, rounds: int):
    """The values minimising the ``power``-norm of ``A c - b`` (iteratively reweighted least
    squares from the least-squares solution; ``power`` 2 is plain least squares)."""
    c, *_ = np.linalg.lstsq(A, b, rcond=None)
    for _ in range(rounds if power != 2 else 0):
        e = np.abs(A @ c - b)
        w = np.maximum(e, 1e-3 * e.max()) ** ((power - 2) / 2)
        c, *_ = np.linalg.lstsq(A * w[:, None], b * w, rcond=None)
    return c


def _norm(e: np.ndarray, power: float) -> float:
    return float(np.mean(np.abs(e) ** power) ** (1 / power))


def fit(images, n_taps: int = 7, radii=(2, 1, 1), evaluations: int = 300,
        power: float = 8.0, rounds: int = 6, start=None) -> tuple[PyramidKernels, dict]:
    """Fit the kernels on ``images`` (zero-border, (n, n)); returns them and the fit's record.

    ``radii``: of each ``g``, finest level first, the last one serving every coarser level.

    The taps minimise the ``power``-norm of the relative error over all pixels (8: close to
    the largest error, with the mean still in view), the ``g`` values are that norm's
    minimiser for the taps (:func:`_solve`). ``start``: initial taps (h1's outer half, h2's
    outer half and centre), default smooth bumps.
    """
    from scipy.optimize import minimize

    def objective(p):
        A, b = _system(p, images, n_taps, radii)
        return _norm(A @ _solve(A, b, power, rounds) - b, power)

    r = n_taps // 2
    p0 = (np.r_[np.linspace(0.05, 0.7, r), np.linspace(0.03, 0.32, r), 0.42] if start is None
          else np.asarray(start, np.float64))
    begin = time.perf_counter()
    if evaluations > 0:
        res = minimize(objective, p0, method="Nelder-Mead",
                       options={"maxfev": evaluations, "xatol": 1e-6, "fatol": 1e-9})
        taps, nfev, best = res.x, int(res.nfev), float(res.fun)
    else:   # keep the starting taps, fit the g values only
        taps, nfev, best = p0, 1, objective(p0)
    A, b = _system(taps, images, n_taps, radii)
    c = _solve(A, b, power, rounds)
    h1, h2 = _taps(taps, n_taps)
    ends = np.cumsum([0] + [len(symmetric_basis(r)) for r in radii])
    g = [list(map(float, c[i:j])) for i, j in zip(ends[:-1], ends[1:])]
    kernels = PyramidKernels(h1, h2, tuple(symmetric_kernel(v, r) for v, r in zip(g, radii)))
    record = {"n_taps": n_taps, "g_radii": list(radii), "power": power,
              "irls_rounds": rounds, "evaluations": nfev, "objective": best, "start": [float(v) for v in p0],
              "seconds": round(time.perf_counter() - begin, 1), "g_values": g}
    return kernels, record


def relative_errors(images, kernels: PyramidKernels) -> list[dict]:
    """Per image: mean and max over pixels of |pyramid - exact| / max|exact|."""
    from runtime_cl.integrate.pyramid_model import pyramid_integrate_numpy

    out = []
    for f in images:
        e = np.abs(pyramid_integrate_numpy(laplacian5(f), kernels) - f) / np.abs(f).max()
        out.append({"size": f.shape[0], "mean": float(e.mean()), "max": float(e.max())})
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m lab.pyramid_fit", description=__doc__.split("\n\n")[0])
    parser.add_argument("--taps", type=int, default=7, help="length of h1 and h2 (odd; default 7)")
    parser.add_argument("--radii", type=int, nargs="+", default=[2, 1, 1],
                        help="radius of each g, finest level first, the last serving every coarser level "
                             "(default 2 1 1: 5x5 at level 0, 3x3 at level 1, 3x3 shared)")
    parser.add_argument("--evaluations", type=int, default=300, help="Nelder-Mead evaluations (default 300; "
                        "0 keeps the --start taps and fits the g values only)")
    parser.add_argument("--power", type=float, default=8.0, help="norm of the relative error minimised (default 8)")
    parser.add_argument("--start", type=float, nargs="+", help="initial taps: h1's outer half, h2's outer "
                        "half and centre (default smooth bumps)")
    parser.add_argument("--out", default=str(KERNELS_FILE), help="kernels file (default: the runtime's)")
    args = parser.parse_args(argv)
    kernels, record = fit(training_set(1), args.taps, tuple(args.radii), args.evaluations,
                          args.power, start=args.start)
    record["train"] = relative_errors(training_set(1), kernels)
    record["check"] = relative_errors(training_set(7), kernels)
    data = {"format": FORMAT, "pad": PAD, "top": TOP, "h1": kernels.h1.tolist(), "h2": kernels.h2.tolist(),
            "g_radii": args.radii, "g": record.pop("g_values"), "fit": record}
    with atomic_path(args.out) as tmp:
        tmp.write_text(json.dumps(data, indent=1) + "\n")
    for name in ("train", "check"):
        worst = max(e["max"] for e in record[name])
        mean = np.mean([e["mean"] for e in record[name]])
        print(f"{name}: mean relative error {mean:.5f}, max {worst:.4f}")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
