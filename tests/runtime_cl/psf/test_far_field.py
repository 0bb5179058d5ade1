"""The far field of a volume database (runtime_cl.psf.far_field): FFT convolution on blocks
against a plain numpy scatter, the bilinear upsampling, sample interpolation and bad pairs."""
import numpy as np
import pytest
from medium_databases import far_database

from runtime_cl.camera.pinhole import Pinhole
from runtime_cl.errors import InputError
from runtime_cl.psf.far_field import FarField, _upsample, check_pair, sample_distances


def brute_force(far, rgb, prepared):
    """Every pixel's colour, split between its two samples, times the sample's far PSF placed at
    its block, summed per block and divided by s^2, then upsampled (float64)."""
    k0, k1, f = prepared.k0, prepared.k1, prepared.f
    s = far.scale
    h, w = rgb.shape[:2]
    hc, wc = -(-h // s), -(-w // s)
    coarse = np.zeros((hc, wc, 3))
    for y in range(h):
        for x in range(w):
            for k, wt in ((k0[y, x], 1.0 - f[y, x]), (k1[y, x], f[y, x])):
                psf = far.db.dense_psf(int(far.order[k])).astype(np.float64)
                r = psf.shape[0] // 2
                by, bx = y // s, x // s
                for j in range(-r, r + 1):
                    for i in range(-r, r + 1):
                        if 0 <= by + j < hc and 0 <= bx + i < wc:
                            coarse[by + j, bx + i] += wt * rgb[y, x] * psf[j + r, i + r]
    return _upsample((coarse / (s * s)).astype(np.float32), h, w, s)


@pytest.mark.parametrize("h, w, scale", [(16, 20, 4), (13, 18, 3)])
def test_far_field_matches_a_plain_scatter(h, w, scale):
    rng = np.random.default_rng(h + w)
    far = FarField(far_database(rng, scale=scale))
    rgb = rng.random((h, w, 3)).astype(np.float32)
    rgb[rng.random((h, w)) < 0.3] = 0.0
    depth = rng.uniform(1.0, 2.5, (h, w)).astype(np.float32)
    prepared = far.prepare(Pinhole(fov_deg=40.0), depth)
    got = far.render(rgb, prepared)
    want = brute_force(far, rgb, prepared)
    np.testing.assert_allclose(got, want, rtol=1e-4, atol=1e-5 * np.abs(want).max())


def test_samples_are_interpolated_linearly_in_distance():
    rng = np.random.default_rng(3)
    far = FarField(far_database(rng, samples=4))
    d = far.distance
    assert np.all(np.diff(d) > 0) and d[0] > 1.0 and d[-1] < 3.0
    np.testing.assert_allclose(np.sort(sample_distances(far.db)), d)
    cam = Pinhole(fov_deg=40.0)
    # one centre pixel (distance = depth) at a sample, between two, beyond the last
    for depth, want in ((d[1], {1: 1.0}), (0.75 * d[1] + 0.25 * d[2], {1: 0.75, 2: 0.25}), (2.99, {len(d) - 1: 1.0})):
        p = far.prepare(cam, np.full((1, 1), depth, np.float32))
        k0, k1, f = p.k0, p.k1, p.f
        weights = np.zeros(len(d))
        np.add.at(weights, [k0[0, 0], k1[0, 0]], [1.0 - f[0, 0], f[0, 0]])
        expected = np.zeros(len(d))
        expected[list(want)] = list(want.values())
        np.testing.assert_allclose(weights, expected, atol=1e-5)


def test_upsampling_keeps_constants_and_ramps():
    c = np.full((4, 5, 3), 2.5, np.float32)
    np.testing.assert_allclose(_upsample(c, 16, 20, 4), 2.5, rtol=1e-6)
    ramp = np.broadcast_to((np.arange(5, dtype=np.float32) * 4 + 1.5)[None, :, None], (4, 5, 3))
    up = _upsample(np.ascontiguousarray(ramp), 16, 20, 4)
    x = np.arange(20, dtype=np.float32)
    inner = (x >= 1.5) & (x <= 17.5)   # between the first and last block centres: exact
    np.testing.assert_allclose(up[0, inner, 0], x[inner], atol=1e-5)


def test_black_frame_has_no_far_field():
    far = FarField(far_database(np.random.default_rng(4)))
    out = far.render(np.zeros((8, 8, 3), np.float32), far.prepare(Pinhole(fov_deg=40.0), np.full((8, 8), 2.0)))
    assert out.shape == (8, 8, 3) and not out.any()


def test_bad_pairs_are_refused():
    rng = np.random.default_rng(5)
    with pytest.raises(InputError, match="need a 'volume_far' database"):
        FarField(far_database(rng, model="volume"))
    far = far_database(rng, hole=5)
    near = far_database(rng, model="volume", psf_resolution=15)    # keeps +-5 px: the hole
    check_pair(near, far)
    with pytest.raises(InputError, match=r"hole 5 px.*window \+-9 px"):
        check_pair(far_database(rng, model="volume", psf_resolution=23), far)
    with pytest.raises(InputError, match="completes a 'volume' database"):
        check_pair(far_database(rng, model="simple_lens"), far)
