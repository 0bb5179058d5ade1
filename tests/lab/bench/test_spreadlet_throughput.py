"""The throughput benchmark: a small run in the fast suite, the 1024^2 figure as a slow check."""
import numpy as np
import pytest

from lab.bench.spreadlet_throughput import rotation, run
from runtime_cl.psf.synthetic import defocus_scene, disc_database


def test_small_benchmark_reports_rates():
    out = run(48, 40, spreadlets=20, r_max=8.0, channels=3, repeats=1)
    assert set(out["methods"]) == {"spreadlets", "splat", "filter"}
    sp = out["methods"]["spreadlets"]
    assert sp["spreadlets"] == 48 * 40 * 20  # every cell in the scene has exactly 20
    assert sp["M_spreadlets_per_s"] > 0
    assert out["methods"]["splat"]["M_dense_pixels_per_s"] > 0
    assert out["device"]["compute_units"] >= 1


@pytest.mark.slow
def test_spreadlet_throughput_at_1024():
    out = run(1024, 1024, spreadlets=50, methods=("spreadlets",), repeats=3)
    rate = out["methods"]["spreadlets"]["M_spreadlets_per_s"]
    print(f"spreadlets: {rate:.0f} M/s")
    # 870 M/s measured with the machine shared by several busy processes (the project's target: 300)
    assert rate > 300


@pytest.mark.slow
def test_spreadlets_beat_splat_tenfold_on_a_defocused_scene():
    # LSR18 Table 2 style: 1024^2, background CoC radii of 55-90 px, discs with a soft rim
    # (r = 80: 1884 spreadlets, ~20 600 non-zero dense pixels). Measured with the 2-core machine
    # shared by several busy processes: kernels 11.2-12.7x, whole methods 8.1-10.1x (the FFT
    # integration is 20-27 % of the spreadlet method's time).
    out = run(1024, 1024, spreadlets=None, r_max=100.0, layout="defocus", samples=64, edge=1.0,
              methods=("spreadlets", "splat"), repeats=2)
    r = out["ratios"]
    print({k: round(v, 2) for k, v in r.items()}, round(out["methods"]["spreadlets"]["M_spreadlets_per_s"]))
    assert r["splat_over_spreadlets_kernel"] >= 10
    assert out["methods"]["spreadlets"]["M_spreadlets_per_s"] >= 650


def nonzero_row_pixels(db):
    """Per sample: pixels from the first to the last non-zero pixel of each row of its dense PSF."""
    out = []
    for i in range(db.n_samples):
        total = 0
        for row in np.any(db.dense_psf(i) != 0, axis=-1):
            cols = np.flatnonzero(row)
            total += cols[-1] - cols[0] + 1 if len(cols) else 0
        out.append(total)
    return np.array(out)


def test_defocus_benchmark_counts_and_ratios():
    out = run(40, 48, spreadlets=None, r_max=10.0, layout="defocus", repeats=1, samples=16, edge=1.0,
              methods=("spreadlets", "splat"))
    db = disc_database(10.0, samples=16, edge=1.0)
    _, coc = defocus_scene(40, 48, 10.0)
    cell = db.grid.index(coc.astype(np.float64))
    sp, splat = out["methods"]["spreadlets"], out["methods"]["splat"]
    assert sp["spreadlets"] == np.diff(db.C)[cell].sum()  # exact Laplacians, every pixel splats
    assert splat["dense_pixels"] == nonzero_row_pixels(db)[cell].sum()  # zero corners are skipped
    assert splat["dense_pixels"] < ((2 * db.dense_radius[cell].astype(int) + 1) ** 2).sum()
    r = out["ratios"]
    assert r["splat_over_spreadlets_kernel"] == splat["kernel_ms"] / sp["kernel_ms"]
    assert 0 < r["integrate_share_of_spreadlets"] < 1
    assert out["settings"]["pad"] == db.pad


def test_defocus_scene_is_scene_like():
    colour, coc = defocus_scene(256, 256, 100.0, seed=3)
    assert colour.shape == (256, 256, 3) and coc.shape == (256, 256, 1)
    assert colour.min() > 0 and 0 <= coc.min() and coc.max() <= 100.0
    r = coc[..., 0]
    assert 0.6 < np.mean((r >= 50) & (r <= 90)) < 0.9  # mostly a far, blurred background
    assert 0.08 < np.mean(r < 1) < 0.25  # an in-focus subject
    assert np.array_equal(defocus_scene(256, 256, 100.0, seed=3)[0], colour)  # seeded


def test_rotation_benchmark_reports_ratios():
    out = rotation(32, 40, r_max=6.0, samples=8, repeats=1)
    ms, ratios = out["kernel_ms"], out["ratios"]
    assert set(ms) == {"spreadlets/unrotated", "spreadlets/unrotated_run_max_1", "spreadlets/constant_bilinear",
                       "spreadlets/constant_nearest", "spreadlets/per_pixel_bilinear", "spreadlets/per_pixel_nearest",
                       "spreadlets/constant_bank", "spreadlets/per_pixel_bank"}
    assert all(v > 0 for v in ms.values())
    key = "spreadlets/per_pixel_nearest"
    assert ratios[f"{key}_over_unrotated"] == ms[key] / ms["spreadlets/unrotated"]
    assert out["settings"]["rotated_pad"] > out["settings"]["pad"]
