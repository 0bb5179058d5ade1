"""Image apertures: the sampler follows the image's transmittance (chi-square), coordinates and
circumradius, built-in star and heart, unreadable or empty files are user errors."""
import hashlib

import drjit as dr
import numpy as np
import pytest
from drjit.llvm import PCG32, Array2f, Float, UInt64
from PIL import Image
from scipy import stats

from lab.errors import UserError
from lab.optics.aperture import make_aperture
from lab.optics.aperture.image import FileImageAperture, load_transmittance
from lab.psf_tracing.tracer import _splitmix64_dr


def rng_points(aperture, n, seed):
    """Points from :meth:`sample_rng` with hashed per-lane PCG32 seeds (as the tracer seeds them)."""
    lane = dr.arange(UInt64, n)
    rng = PCG32(n, _splitmix64_dr(lane + UInt64(2 * seed)), _splitmix64_dr(lane + UInt64(2 * seed + 1)))
    p = aperture.sample_rng(rng)
    return p.x.numpy().astype(np.float64), p.y.numpy().astype(np.float64)


def sample_points(aperture, n, seed):
    rng = np.random.default_rng(seed)
    u = rng.random((2, n), dtype=np.float32)
    p = aperture.sample(Array2f(Float(u[0]), Float(u[1])))
    return p.x.numpy().astype(np.float64), p.y.numpy().astype(np.float64)


def write_png(path, array, mode="L"):
    Image.fromarray(array, mode=mode).save(path)
    return str(path)


@pytest.fixture
def pattern(tmp_path):
    """A 12 x 16 grey pattern with empty rows and columns around and inside it."""
    rng = np.random.default_rng(0)
    img = (rng.random((12, 16)) * 255).astype(np.uint8)
    img[:, :3] = 0
    img[5] = 0
    img[-2:] = 0
    img[2, 7] = 0
    return img, write_png(tmp_path / "pattern.png", img)


def pixel_of(ap, x, y):
    h, w = ap.weights.shape
    rc = ap._geometry[2]
    return np.floor(h / 2 - y * rc).astype(int), np.floor(x * rc + w / 2).astype(int)


@pytest.mark.parametrize("draw", [sample_points, rng_points], ids=["inverse-cdf", "alias"])
def test_sampler_follows_the_transmittance(pattern, draw):
    img, path = pattern
    ap = make_aperture("image", path=path)
    n = 400_000
    x, y = draw(ap, n, seed=1)
    rows, cols = pixel_of(ap, x, y)
    assert rows.min() >= 0 and cols.min() >= 0 and rows.max() < 12 and cols.max() < 16
    counts = np.bincount(rows * 16 + cols, minlength=12 * 16).reshape(12, 16)
    w = img.astype(np.float64)
    assert np.all(counts[w == 0] == 0)  # never a blocked pixel
    open_ = w > 0
    expected = n * w[open_] / w.sum()
    assert stats.chisquare(counts[open_], expected).pvalue > 1e-3
    # inside a pixel the position is uniform (the leftover fractions are used, not discarded)
    h, wd, rc, _ = ap._geometry
    fx = x * rc + wd / 2 - cols
    fy = h / 2 - y * rc - rows
    for f in (fx, fy):
        assert stats.kstest(f, "uniform").pvalue > 1e-3


def test_coordinates_centre_and_circumradius(tmp_path):
    img = np.zeros((10, 10), np.uint8)
    img[1, 8] = 255  # one open pixel, up and right of the centre (5, 5)
    ap = make_aperture("image", path=write_png(tmp_path / "dot.png", img))
    x, y = sample_points(ap, 10_000, seed=2)
    # pixel spans columns 8..9 and rows 1..2 -> x in [3, 4] / rc, y in [3, 4] / rc, rc = |(4, 4)|
    rc = np.hypot(4, 4)
    assert ap._geometry[2] == pytest.approx(rc)
    assert x.min() >= 3 / rc - 1e-6 and x.max() <= 4 / rc + 1e-6
    assert y.min() >= 3 / rc - 1e-6 and y.max() <= 4 / rc + 1e-6
    assert np.hypot(x, y).max() <= 1 + 1e-6
    assert ap.area == pytest.approx(1 / rc ** 2)


def test_alpha_and_luminance(tmp_path):
    rgba = np.zeros((4, 4, 4), np.uint8)
    rgba[..., :3] = 255
    rgba[0, 0, 3] = 255   # opaque white: open
    rgba[1, 1, 3] = 128   # half transparent: half
    rgba[2, 2, :3] = 0    # black
    rgba[2, 2, 3] = 255
    w, digest = load_transmittance(write_png(tmp_path / "a.png", rgba, "RGBA"))
    assert w[0, 0] == pytest.approx(1.0) and w[1, 1] == pytest.approx(128 / 255)
    assert w[2, 2] == 0 and w[3, 3] == 0
    assert digest == hashlib.sha256((tmp_path / "a.png").read_bytes()).hexdigest()


@pytest.mark.parametrize("draw", [sample_points, rng_points], ids=["inverse-cdf", "alias"])
@pytest.mark.parametrize("name", ["star", "heart"])
def test_builtins(name, draw):
    ap = make_aperture(name)
    x, y = draw(ap, 200_000, seed=3)
    assert ap.contains(x, y).all()
    assert np.hypot(x, y).max() == pytest.approx(1.0, abs=0.02)
    assert 0.2 < ap.area < np.pi
    # the probability of a region is its area share: the upper half vs the indicator's share
    t = (np.arange(1000) + 0.5) / 1000 * 2 - 1
    wgt = ap.weight(t[None, :], t[:, None])
    share_up = wgt[t > 0].sum() / wgt.sum()
    assert np.mean(y > 0) == pytest.approx(share_up, abs=0.01)


def test_builtin_orientation():
    x, y = sample_points(make_aperture("star"), 200_000, seed=4)
    top = np.argmax(y)
    assert abs(x[top]) < 0.05 and y[top] > 0.95      # a tip straight up
    x, y = sample_points(make_aperture("heart"), 200_000, seed=5)
    low = np.argmin(y)
    assert abs(x[low]) < 0.05                        # the point at the bottom


def test_unreadable_files_are_user_errors(tmp_path):
    with pytest.raises(UserError, match=r"aperture_image .*missing\.png: no such file; give the path of a PNG"):
        make_aperture("image", path=str(tmp_path / "missing.png"))
    junk = tmp_path / "junk.png"
    junk.write_bytes(b"not a png at all")
    with pytest.raises(UserError, match=r"junk\.png.*cannot be read \(no image format Pillow reads\)") as e:
        make_aperture("image", path=str(junk))
    assert "BytesIO" not in str(e.value)
    empty = tmp_path / "empty.png"
    empty.write_bytes(b"")
    with pytest.raises(UserError, match=r"empty\.png.*cannot be read \(an empty file\)"):
        make_aperture("image", path=str(empty))
    black = write_png(tmp_path / "black.png", np.zeros((8, 8), np.uint8))
    with pytest.raises(UserError, match="no open pixel"):
        make_aperture("image", path=black)
    with pytest.raises(UserError, match="PNG"):
        FileImageAperture("")


def test_digest_pins_the_file(tmp_path):
    img = np.full((6, 6), 200, np.uint8)
    path = write_png(tmp_path / "p.png", img)
    ap = make_aperture("image", path=path)
    assert make_aperture("image", path=path, sha256=ap.digest).digest == ap.digest
    img[0, 0] = 0
    write_png(tmp_path / "p.png", img)
    with pytest.raises(UserError, match="the image changed"):
        make_aperture("image", path=path, sha256=ap.digest)


def test_builtin_heart_is_the_polygon_kernels_heart():
    """Same outline as runtime_cl.polygon.shapes (its y runs down): traced and MHU21 bokeh agree."""
    from lab.optics.aperture.builtin import polygon_mask, heart_raster
    from runtime_cl.polygon.shapes import shape

    v = shape("heart") * np.array([1.0, -1.0])
    theirs = polygon_mask(v, 512)
    ours = heart_raster() >= 0.5
    assert (theirs & ours).sum() / (theirs | ours).sum() > 0.99


def test_too_large_image(tmp_path, monkeypatch):
    import lab.optics.aperture.image as mod

    monkeypatch.setattr(mod, "MAX_IMAGE_SIDE", 32)
    path = write_png(tmp_path / "big.png", np.full((20, 40), 255, np.uint8))
    with pytest.raises(UserError, match=r"40 x 20 pixels; at most 32 per side"):
        make_aperture("image", path=path)


def test_a_coloured_aperture_is_refused_but_grey_saved_as_rgb_is_read(tmp_path):
    rgb = np.full((4, 4, 3), 200, np.uint8)
    w, _ = load_transmittance(write_png(tmp_path / "grey.png", rgb, "RGB"))
    assert np.allclose(w, 200 / 255)
    rgb[1, 2] = (255, 0, 0)
    with pytest.raises(UserError, match=r"has colour \(1 pixel\(s\).*grayscale PNG"):
        load_transmittance(write_png(tmp_path / "red.png", rgb, "RGB"))
