"""The PSF atlas of a spreadlet database: one PNG showing what the precompute made of the PSF space.

Columns are PSF samples spread evenly over the PSF space (in its power-remapped grid coordinates,
so they follow the sample density); for a 2-D space each block of rows is one value of the first
coordinate. Per sample, four tiles, each zoomed to that sample's own extent (its radius is in the
caption) and shown on a log scale over 4 decades below the tile's peak, so faint tails (a
medium's scattering halo, a lens's flare) show beside the peak:

1. the dense pre-filtered PSF (RGB models in colour),
2. its Laplacian (5-point, summed over channels; red > 0, blue < 0),
3. the spreadlets (each a dot at its offset, coloured by the sign of its value summed over
   channels), or "fast track" when the sample is stored dense,
4. the PSF reconstructed from the spreadlets by Poisson integration, on the dense tile's scale:
   what the runtime draws.

Downscaled tiles keep the extreme value of each block (max-|.| pooling), so one-pixel rims and
single spreadlets stay visible at any zoom.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from runtime_cl.integrate.poisson import laplacian5, poisson_integrate

from .images import save_png, to_uint8

__all__ = ["AtlasFiles", "select_cells", "render_atlas", "write_atlas", "caption_height"]

TILE = 144
GAP = 6
LEFT = 96
TITLE = 34
DECADES = 4.0  # every tile is on a log scale over this many decades below its peak
ROWS = ("dense PSF", "Laplacian", "spreadlets", "reconstructed")


def caption_height(ns: int) -> int:
    """Pixels of caption above each block of tiles: index and radius, one line per coordinate, stats."""
    return 14 * (ns + 2) + 6


@dataclass(frozen=True)
class AtlasFiles:
    """What :func:`write_atlas` wrote: the atlas PNG and LSR18 Table 1 as markdown and JSON."""

    png: Path
    markdown: Path
    json: Path
    cells: tuple


def select_cells(db, columns: int = 8, blocks: int = 4) -> list[list[int]]:
    """Sample indices to show, as rows of cells: ``columns`` per row, ``blocks`` rows for a 2-D space.

    Each target is a point of a lattice over the grid coordinates [0, n]^ns; the cell whose box
    centre is nearest is shown (repeats removed). Dimensions beyond the second sit at their middle,
    a uniform (binned) last one in its first bin (a motion angle: the bin centred on 0 degrees).
    """
    from lab.psf_tracing.space import boxes

    grid = db.grid
    centres = np.array([[(a + b) / 2 for a, b in zip(bx.grid_lo, bx.grid_hi)] for bx in boxes(grid)])
    per_dim = [columns] if grid.ns == 1 else [blocks, columns] + [1] * (grid.ns - 2)
    axes = [np.linspace(0, grid.n, k) if k > 1 else np.array([grid.n / 2]) for k in per_dim]
    if grid.bins:
        axes[-1] = np.array([0.5])
    rows = []
    for first in axes[0] if grid.ns > 1 else [None]:
        row = []
        for rest in (axes[1] if grid.ns > 1 else axes[0]):
            target = [rest] if grid.ns == 1 else [first, rest] + [a[0] for a in axes[2:]]
            cell = int(np.argmin(((centres - np.array(target)) ** 2).sum(axis=1)))
            if cell not in row:
                row.append(cell)
        rows.append(row)
    return rows


def _pool(values: np.ndarray, tile: int) -> np.ndarray:
    """(S, S[, 3]) -> at most (tile, tile[, 3]): blocks reduced to their max-|.| value."""
    k = max(1, math.ceil(values.shape[0] / tile))
    if k == 1:
        return values
    pad = (-values.shape[0]) % k
    v = np.pad(values, [(0, pad), (0, pad)] + [(0, 0)] * (values.ndim - 2))
    s = v.shape[0] // k
    blocks = v.reshape(s, k, s, k, *v.shape[2:]).swapaxes(1, 2).reshape(s, s, k * k, *v.shape[2:])
    idx = np.abs(blocks).argmax(axis=2)
    return np.take_along_axis(blocks, idx[:, :, None], axis=2)[:, :, 0]


def _tile(rgb: np.ndarray, tile: int) -> Image.Image:
    return Image.fromarray(to_uint8(rgb)).resize((tile, tile), Image.NEAREST)


def _log(x: np.ndarray) -> np.ndarray:
    """|values| relative to the tile's peak on a log scale: 1 at the peak, 0 at DECADES below."""
    return np.clip(1.0 + np.log10(np.maximum(np.abs(x), 1e-30)) / DECADES, 0.0, 1.0)


def _heat(values: np.ndarray, top: float, tile: int) -> Image.Image:
    from matplotlib import colormaps

    v = _log(np.maximum(_pool(values, tile), 0.0) / top)
    if v.ndim == 3 and v.shape[2] == 3:
        return _tile(v, tile)
    return _tile(colormaps["magma"](v.reshape(v.shape[:2]))[..., :3], tile)


def _signed(values: np.ndarray, tile: int) -> Image.Image:
    from matplotlib import colormaps

    v = _pool(values, tile)
    s = v / (float(np.abs(v).max()) or 1.0)
    return _tile(colormaps["RdBu_r"](0.5 + 0.5 * np.sign(s) * _log(s))[..., :3], tile)


def _cell_tiles(db, i: int, tile: int) -> list[Image.Image]:
    dense = db.dense_psf(i).astype(np.float64)
    r = (dense.shape[0] - 1) // 2
    side = 2 * (r + 2) + 1  # two empty pixels around the crop: the Laplacian's rim fits
    psf = np.zeros((side, side, db.channels))
    psf[2:-2, 2:-2] = dense
    top = float(psf.max()) or 1.0
    tiles = [_heat(psf, top, tile), _signed(laplacian5(psf).sum(axis=2), tile)]
    points, values = db.spreadlets(i)
    if db.fast_track[i]:
        tiles += [_fast_track(tile), _heat(psf, top, tile)]
        return tiles
    lap = np.zeros((side, side, db.channels))
    c = side // 2
    inside = (np.abs(points.astype(np.int64)) <= c - 1).all(axis=1)
    np.add.at(lap, (c + points[inside, 1].astype(np.int64), c + points[inside, 0].astype(np.int64)),
              values[inside])
    tiles.append(_signed(lap.sum(axis=2), tile))
    tiles.append(_heat(poisson_integrate(lap), top, tile))
    return tiles


def _font(size: int):
    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1
        return ImageFont.load_default()


def _fast_track(tile: int) -> Image.Image:
    img = Image.new("RGB", (tile, tile), (40, 40, 40))
    ImageDraw.Draw(img).text((tile // 2, tile // 2), "fast track\n(dense)", fill=(230, 230, 230),
                             font=_font(13), anchor="mm", align="center")
    return img


def _caption(db, i: int) -> str:
    from lab.psf_tracing.space import box

    centre = box(db.grid, i).centre
    coords = "\n".join(f"{n[:16]} {x:.3g}" for n, x in zip(db.grid.names, centre))
    n = int(db.C[i + 1] - db.C[i])
    stats = "fast track" if db.fast_track[i] else (f"{n} spl {100 * db.stats['sparsity'][i]:.0f}% "
                                                   f"SSIM {db.stats['ssim'][i]:.2f}")
    return f"#{i}  r {int(db.dense_radius[i])} px\n{coords}\n{stats}"


def render_atlas(db, columns: int = 8, blocks: int = 4, tile: int = TILE) -> tuple[Image.Image, tuple]:
    """The atlas of ``db`` as a PIL image and the cells shown (see the module docstring)."""
    rows = select_cells(db, columns, blocks)
    width = LEFT + max(len(r) for r in rows) * (tile + GAP) + GAP
    cap_h, title_h = caption_height(db.grid.ns), TITLE
    block_h = cap_h + len(ROWS) * (tile + GAP)
    img = Image.new("RGB", (width, title_h + len(rows) * block_h + GAP), (255, 255, 255))
    draw = ImageDraw.Draw(img)
    kind = "RGB" if db.channels == 3 else "monochrome"
    draw.text((GAP, 8), f"{db.model}: {db.n_samples} PSF samples, beta {list(db.grid.beta)}, {kind}, "
                        f"{db.psf_resolution}^2 traced; each tile zoomed to its PSF, log scale over "
                        f"{DECADES:g} decades", fill=(0, 0, 0),
              font=_font(15))
    small = _font(11)
    for b, row in enumerate(rows):
        y0 = title_h + b * block_h
        for k, name in enumerate(ROWS):
            draw.text((GAP, y0 + cap_h + k * (tile + GAP) + tile // 2), name, fill=(0, 0, 0), font=small,
                      anchor="lm")
        for j, cell in enumerate(row):
            x = LEFT + j * (tile + GAP)
            draw.multiline_text((x, y0 + 4), _caption(db, cell), fill=(0, 0, 0), font=small, spacing=2)
            for k, t in enumerate(_cell_tiles(db, cell, tile)):
                img.paste(t, (x, y0 + cap_h + k * (tile + GAP)))
    return img, tuple(c for row in rows for c in row)


def write_atlas(db, out_dir, columns: int = 8, blocks: int = 4) -> AtlasFiles:
    """Write ``atlas.png``, ``table.md`` and ``table.json`` (LSR18 Table 1 row) to ``out_dir``.

    Parameters
    ----------
    db : SpreadletDatabase
        A loaded database (its file size goes into the table).
    out_dir : str or Path
        Folder to write into (created).
    columns, blocks : int
        Samples per row, and rows of samples for 2-D PSF spaces (defaults 8 and 4).
    """
    from .table1 import table1_row, write_table1

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    img, cells = render_atlas(db, columns, blocks)
    save_png(img, out / "atlas.png")
    md, js = write_table1([table1_row(db)], out, "table")
    return AtlasFiles(out / "atlas.png", md, js, cells)
