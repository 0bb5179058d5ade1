"""A check figure for one sparsified PSF: PSF, Laplacian (or row differences), spreadlets,
reconstruction, error."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .laplacian import psf_laplacian, working_box
from .spreadlets import SparsePSF

__all__ = ["save_check_figure"]


def save_check_figure(psf: np.ndarray, sparse: SparsePSF, path: str | Path,
                      title: str = "") -> Path:
    """Write a PNG with five panels on the PSF's working box (channel mean for RGB).

    Parameters
    ----------
    psf : ndarray, (R, R, C)
        The dense PSF given to :func:`lab.sparsify.sparsify`.
    sparse : SparsePSF
        Its sparsification.
    path : str or Path
        Output PNG; parent directories are created.
    title : str, optional
        Figure title (the statistics are appended).

    Returns
    -------
    Path
        The written file.
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    res = psf.shape[0]
    lap = psf_laplacian(psf)
    box = working_box(psf, lap)
    rec = sparse.reconstruct(res)
    rows = sparse.basis == "rows"
    if rows:   # what the row spreadlets fit: the PSF's backward differences along x
        lap = np.diff(np.asarray(psf, np.float64), axis=1, prepend=0.0)
    f, l, r = (box.crop(np.asarray(a, np.float64)).mean(axis=2) for a in (psf, lap, rec))
    c = res // 2
    vmax = max(f.max(), 1e-30)
    lmax = max(np.abs(l).max(), 1e-30)
    fig, ax = plt.subplots(1, 5, figsize=(20, 4.4))
    ax[0].imshow(f, cmap="gray", vmin=0, vmax=vmax)
    ax[0].set_title("dense PSF")
    ax[1].imshow(l, cmap="RdBu_r", vmin=-lmax, vmax=lmax)
    ax[1].set_title("row differences" if rows else "Laplacian")
    ax[2].imshow(l, cmap="RdBu_r", vmin=-lmax, vmax=lmax, alpha=0.35)
    if len(sparse.points):
        v = sparse.values.astype(np.float64).mean(axis=1)
        ax[2].scatter(sparse.points[:, 0] + c - box.x0, sparse.points[:, 1] + c - box.y0,
                      c=np.sign(v), cmap="bwr", s=6, vmin=-1, vmax=1)
    ax[2].set_title(f"{'row ' if rows else ''}spreadlets ({len(sparse.points)})")
    ax[3].imshow(r, cmap="gray", vmin=0, vmax=vmax)
    ax[3].set_title("reconstruction" + (" (fast track)" if sparse.fast_track else ""))
    err = ax[4].imshow(r - f, cmap="RdBu_r", vmin=-0.25 * vmax, vmax=0.25 * vmax)
    ax[4].set_title("rec - PSF (+-25% of max)")
    fig.colorbar(err, ax=ax[4], fraction=0.046)
    for a in ax:
        a.set_xticks([])
        a.set_yticks([])
    s = sparse.stats
    fig.suptitle(f"{title}  sparsity {100 * s['sparsity']:.2f}%  n={s['n_points']:.0f}  "
                 f"SSIM {s['ssim']:.3f}  L1 {s['l1']:.3f}  fast_track={sparse.fast_track}")
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path
