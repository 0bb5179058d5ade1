"""PSF atlas PNGs and LSR18 Table 1 from databases."""
import json
from types import SimpleNamespace

import numpy as np
import pytest
from PIL import Image

from lab.report.atlas import GAP, LEFT, TILE, TITLE, caption_height, render_atlas, select_cells, write_atlas
from lab.report.table1 import table1_markdown, table1_row
from runtime_cl.psf.database import DatabaseBuilder
from runtime_cl.integrate.poisson import laplacian5
from runtime_cl.psf.grid import NestedGrid
from runtime_cl.psf.disc import disc_psf


def test_atlas_and_table_of_a_traced_database(reference, tmp_path):
    db, _ = reference
    files = write_atlas(db, tmp_path / "atlas", columns=5)
    img = np.asarray(Image.open(files.png).convert("RGB"))
    assert img.shape[1] == LEFT + len(files.cells) * (TILE + GAP) + GAP
    assert len(set(files.cells)) == len(files.cells) >= 4
    # the first column is the smallest PSF (a delta): its dense tile is bright in the middle only
    top = TITLE + caption_height(1)
    tile = img[top:top + TILE, LEFT:LEFT + TILE].astype(int).sum(axis=2)
    assert tile[TILE // 2, TILE // 2] > 300 and tile[5, 5] < 60
    rows = json.loads(files.json.read_text())["rows"]
    assert len(rows) == 1
    row = rows[0]
    assert row["samples"] == db.n_samples and row["beta"] == [2.0] and row["ns"] == 1
    assert row["mean_similarity_ssim"] == pytest.approx(float(np.mean(db.stats["ssim"])))
    drawn = np.where(db.fast_track, 1.0, db.stats["sparsity"])
    assert row["mean_sparsity_percent"] == pytest.approx(100 * drawn.mean(), rel=1e-5)
    assert 0 < row["mean_sparsity_percent"] <= 100
    sparse = db.stats["sparsity"][~db.fast_track]
    if len(sparse):   # LSR18 Fig. 10's figure: the spreadlet-stored samples alone
        assert row["sparse_only_sparsity_percent"] == pytest.approx(100 * sparse.mean(), rel=1e-5)
        assert row["sparse_only_sparsity_percent"] <= row["mean_sparsity_percent"] + 1e-9
    assert row["size_MB"] * 1e6 == pytest.approx(db.path.stat().st_size)
    assert row["lsr18"]["samples"] == 100 and row["lsr18"]["mean_sparsity_percent"] == 31.3
    md = files.markdown.read_text()
    assert "| simple_lens (ours) | 1 | no |" in md and "| simple_lens (LSR18) |" in md


def test_cells_of_a_2d_space_cover_its_corners():
    grid = NestedGrid.for_samples(400, (2.0, 1.0), ((0.0, 10.0), (0.0, 5.0)), ("coc", "motion"))
    rows = select_cells(SimpleNamespace(grid=grid), columns=6, blocks=4)
    assert len(rows) == 4 and all(4 <= len(r) <= 6 for r in rows)
    from lab.psf_tracing.space import boxes

    b = boxes(grid)
    first, last = b[rows[0][0]], b[rows[-1][-1]]
    assert first.lo == (0.0, 0.0) and last.hi == (10.0, 5.0)
    along_first = [b[r[0]].centre[0] for r in rows]
    assert along_first == sorted(along_first) and along_first[0] < along_first[-1]


def _rgb_2d_database():
    """Chromatic discs (radius per channel grows with both coordinates), exact spreadlets."""
    grid = NestedGrid.for_samples(20, (1.0, 1.0), ((1.0, 6.0), (0.0, 2.0)), ("depth", "ecc"))
    from lab.psf_tracing.space import boxes

    builder = DatabaseBuilder("physical_lens", {}, grid, 3, 21)
    for bx in boxes(grid):
        d, e = bx.centre
        discs = [disc_psf(d + e * k) for k in range(3)]
        r = max(p.shape[0] for p in discs) // 2
        dense = np.zeros((2 * r + 1, 2 * r + 1, 3))
        for k, p in enumerate(discs):
            o = r - p.shape[0] // 2
            dense[o:o + p.shape[0], o:o + p.shape[0], k] = p
        lap = laplacian5(np.pad(dense, ((1, 1), (1, 1), (0, 0))))
        ys, xs = np.nonzero(np.abs(lap).sum(axis=2) > 0)
        pts = np.column_stack([xs - (r + 1), ys - (r + 1)])
        builder.add(pts, lap[ys, xs], dense, fast_track=bool(d < 1.5),
                    stats={"sparsity": len(pts) / (dense.shape[0] ** 2), "ssim": 1.0, "l1": 0.0})
    return builder.build()


def test_rgb_2d_atlas_shows_colour_and_every_row(tmp_path):
    db = _rgb_2d_database()
    img, cells = render_atlas(db, columns=4, blocks=3)
    a = np.asarray(img).astype(int)
    rows = select_cells(db, 4, 3)
    block = caption_height(2) + 4 * (TILE + GAP)
    assert len(rows) == 3 and a.shape[0] == TITLE + 3 * block + GAP
    # the last sample's dense tile is coloured (channels differ: chromatic discs), and its
    # reconstruction from the exact spreadlets looks the same as the dense tile
    y0 = TITLE + 2 * block + caption_height(2)
    x0 = LEFT + (len(rows[-1]) - 1) * (TILE + GAP)
    dense = a[y0:y0 + TILE, x0:x0 + TILE]
    rec = a[y0 + 3 * (TILE + GAP):y0 + 3 * (TILE + GAP) + TILE, x0:x0 + TILE]
    assert np.abs(dense[..., 0] - dense[..., 2]).max() > 100
    assert np.abs(dense - rec).mean() < 3
    row = table1_row(db)
    assert row["color"] and row["ns"] == 2 and row["lsr18"]["samples"] == 4000
    assert f"physical_lens (ours) | 2 | yes | {db.n_samples} |" in table1_markdown([row])
