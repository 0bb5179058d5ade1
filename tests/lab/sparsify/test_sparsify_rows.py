"""Row-difference spreadlets (``sparsify(..., basis="rows")``, lab/sparsify/rows.py): exact on
flat shapes, sparser than the Laplacian at a higher SSIM on traced discs, blind to ray noise,
rows closed exactly in float32."""
import numpy as np
import pytest

from lab.errors import UserError
from lab.psf_tracing.analytic import prefiltered_disc_psf
from lab.sparsify import analytic
from lab.sparsify.rows import fit_rows, row_terms
from lab.sparsify.spreadlets import sparsify
from lab.sparsify.stats import similarity
from lab.sparsify.laplacian import psf_laplacian, working_box


def crescent(size=81, r=24.0, shift=9.0):
    """A flat crescent (a disc less a shifted disc), normalised: no symmetry a row fit could use."""
    yy, xx = np.mgrid[0:size, 0:size] - size // 2
    shape = (np.hypot(xx, yy) < r) & ~(np.hypot(xx - shift, yy + 0.4 * shift) < 0.8 * r)
    psf = shape.astype(np.float64)[..., None]
    return psf / psf.sum()


def test_a_flat_shape_is_stored_exactly_with_two_terms_per_edge():
    psf = crescent()
    sp = sparsify(psf, basis="rows")
    assert not sp.fast_track and sp.basis == "rows"
    rec = sp.reconstruct(psf.shape[0])
    np.testing.assert_allclose(rec, psf, rtol=0, atol=1e-7 * psf.max())
    # one jump where each row enters the shape and one where it leaves
    rows = psf[..., 0] > 0
    edges = int(np.count_nonzero(np.diff(rows.astype(np.int8), axis=1, prepend=0, append=0)))
    assert len(sp.points) == edges
    assert sp.stats["sparsity"] < 0.15


def test_a_traced_disc_needs_half_the_laplacian_terms_at_a_higher_ssim(ray_histogram):
    truth = prefiltered_disc_psf(20.0, 21.0, 127)[..., None]
    rays = int(8192 * np.pi * 21.0 ** 2)
    traced = ray_histogram(truth, rays)
    box = working_box(truth, psf_laplacian(truth))
    scores = {}
    for basis in ("laplacian", "rows"):
        sp = sparsify(traced, rays=rays, basis=basis)
        scores[basis] = (len(sp.points), similarity(truth, sp.reconstruct(127), box)[0])
    (n_lap, ssim_lap), (n_rows, ssim_rows) = scores["laplacian"], scores["rows"]
    assert n_rows < 0.6 * n_lap
    assert ssim_rows > ssim_lap and ssim_rows > 0.97


def test_the_fit_does_not_follow_ray_noise(ray_histogram):
    square = np.zeros((64, 64, 1))
    square[12:52, 16:48] = 1.0
    square /= square.sum()
    traced = ray_histogram(square, 256 * 40 * 32)   # 256 rays per pixel: 6 % noise
    sp = sparsify(traced, rays=256 * 40 * 32, basis="rows")
    ys = sp.points[:, 1]
    assert len(np.unique(ys)) == 40
    assert np.bincount(ys - ys.min()).max() == 2   # every row: in, out
    rec = sp.reconstruct(64)
    inside = rec[12:52, 16:48, 0]
    assert np.ptp(inside, axis=1).max() <= 1e-6 * inside.max()   # each row one flat segment


def test_density_trades_terms_for_accuracy():
    psf = analytic.prefiltered_disc(112, 40.0, 3.0)
    sparse, dense = (sparsify(psf, basis="rows", density=d) for d in (0.25, 4.0))
    assert len(sparse.points) < len(dense.points)
    assert sparse.stats["ssim"] < dense.stats["ssim"]
    assert dense.stats["ssim"] > 0.99


def test_rows_close_exactly_in_float32():
    rng = np.random.default_rng(3)
    psf = analytic.rgb_discs(64, (11.0, 13.0, 15.0)) * rng.uniform(0.5, 2.0, 3)
    points, values = row_terms(fit_rows(psf, 0.01))
    for y in np.unique(points[:, 1]):
        run = np.zeros(3, np.float32)
        for v in values[points[:, 1] == y]:
            run = run + v
        assert np.all(run == 0), y


def test_small_psfs_are_sparse_or_dense_whichever_is_smaller():
    delta = np.zeros((31, 31, 1))
    delta[15, 15] = 1.0
    sp = sparsify(delta, basis="rows")
    assert sp.fast_track and sp.basis == "rows"
    np.testing.assert_array_equal(sp.reconstruct(31), delta)
    small = prefiltered_disc_psf(5.0, 5.5, 31)[..., None]
    sp = sparsify(small, basis="rows")
    assert not sp.fast_track and sp.stats["sparsity"] < 0.6 and sp.stats["ssim"] > 0.99
    # a PSF a pixel or two wide is mostly ramp: refitted until within 5 % L1, or dense
    for lo, hi in ((0.9, 1.1), (1.2, 1.6), (1.6, 2.0)):
        sp = sparsify(prefiltered_disc_psf(lo, hi, 31)[..., None], basis="rows")
        assert sp.fast_track or sp.stats["l1"] <= 0.05, (lo, sp.stats)


def test_an_unknown_basis_is_refused():
    with pytest.raises(UserError, match="basis = 'haar'.*laplacian.*rows"):
        sparsify(crescent(), basis="haar")
