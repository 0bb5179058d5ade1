"""Stylized: the PSF is the aperture image scaled to the CoC (IoU, L1 against the image), per-channel
scale moves the channels apart, the near side is turned by 180 degrees, images and errors."""
import numpy as np
import pytest
from PIL import Image

from lab.config import from_table, to_table
from lab.errors import UserError
from lab.psf_tracing.models import get_model, load_model
from lab.psf_tracing.models.simple_lens import min_psf_resolution
from lab.psf_tracing.models.stylized import Stylized, StylizedConfig

R = 61
N_RAYS = 3 * 2 ** 19
BASE = {"max_coc_px": 26.0, "psf_resolution": R, "rays_per_psf": 3 * 2 ** 16, "rays_per_pixel": 16,
        "rays_per_launch": 2 ** 20}


def shape_reference(aperture, r, resolution=R, ss=16):
    """Pixel shares of the aperture's transmittance scaled to radius r as the near side shows it
    (image offset, x right / y up, = -r * aperture point), supersampled ss x ss per pixel."""
    c = resolution // 2
    sub = (np.arange(resolution * ss) + 0.5) / ss - 0.5 - c
    x, y_up = sub[None, :], -sub[:, None]
    w = aperture.weight(-x / r, -y_up / r) if hasattr(aperture, "weight") else \
        aperture.contains(-x / r, -y_up / r).astype(np.float64)
    w = w.reshape(resolution, ss, resolution, ss).sum(axis=(1, 3))
    return w / w.sum()


def l1_noise(ref, n):
    return float(np.sum(np.sqrt(2 / np.pi * ref * (1 - ref) / n)))


def iou(a, b):
    return (a & b).sum() / (a | b).sum()


def test_defaults_follow_lsr18_table_1():
    m = Stylized(StylizedConfig(max_coc_px=100.0))
    assert get_model("stylized") is Stylized
    assert m.grid.ns == 1 and m.channels == 3 and m.beta == (1.5,) and m.grid.size >= 200
    assert m.symmetries == ("coc_sign",) and m.config.aperture == "star"
    assert m.config.channel_scale == (1.0, 0.95, 0.9)


@pytest.mark.parametrize("shape", ["star", "heart"])
def test_psf_is_the_aperture_image_scaled_to_the_coc(shape):
    r = 25.0
    m = load_model("stylized", {**BASE, "aperture": shape, "channel_scale": [1.0, 1.0, 1.0]})
    res = m.trace_box([r], [r], n_rays=N_RAYS, seed=1)
    assert res.n_outside == 0
    ref = shape_reference(m.aperture, r)
    for c in range(3):
        psf = res.psf[..., c].astype(np.float64)
        assert psf.sum() == pytest.approx(1.0, abs=1e-6)
        n_c = int(res.counts[..., c].sum())
        assert abs(n_c - N_RAYS / 3) < 5 * np.sqrt(N_RAYS / 3)  # channels drawn uniformly
        assert iou(psf > 0, ref > 0) > 0.95
        assert np.abs(psf - ref).sum() < 1.3 * l1_noise(ref, n_c) + 0.01
    # stored is the near side: a star's tip points down (row index grows downward)
    if shape == "star":
        rows = np.flatnonzero(res.psf[:, R // 2, 0] > 0) - R // 2
        assert rows.max() >= round(0.97 * r) and -rows.min() < 0.9 * r


def test_per_channel_scale_moves_the_channels_apart():
    r, scale = 24.0, (1.0, 0.8, 0.6)
    m = load_model("stylized", {**BASE, "aperture": "circle", "channel_scale": list(scale)})
    psf = m.trace_box([r], [r], n_rays=N_RAYS, seed=2).psf.astype(np.float64)
    k = np.arange(R) - R // 2
    d2 = k[None, :] ** 2 + k[:, None] ** 2
    for c, s in enumerate(scale):
        # a uniform disc of radius s r: E[d^2] = (s r)^2 / 2, plus 1/6 for pixel binning
        assert (psf[..., c] * d2).sum() == pytest.approx((s * r) ** 2 / 2 + 1 / 6, rel=0.01)
        reach = np.sqrt(d2[psf[..., c] > 0].max())
        assert s * r - 1 < reach <= s * r + np.sqrt(0.5)
    # the fringe: only red beyond the green disc
    ring = (d2 > (0.85 * r) ** 2) & (d2 < (0.95 * r) ** 2)
    assert psf[ring, 0].min() > 0 and psf[ring, 1].max() == 0 and psf[ring, 2].max() == 0


def test_user_png_with_grey_levels(tmp_path):
    img = np.zeros((40, 40), np.uint8)
    img[4:36, 4:12] = 255    # an "L": bright upright bar ...
    img[28:36, 12:34] = 100  # ... and a dimmer foot to the right
    path = tmp_path / "ell.png"
    Image.fromarray(img).save(path)
    r = 25.0
    m = load_model("stylized", {**BASE, "aperture": "image", "aperture_image": str(path),
                                "channel_scale": [1.0, 1.0, 1.0]})
    res = m.trace_box([r], [r], n_rays=N_RAYS, seed=3)
    ref = shape_reference(m.aperture, r)
    psf = res.psf[..., 1].astype(np.float64)
    assert np.abs(psf - ref).sum() < 1.3 * l1_noise(ref, int(res.counts[..., 1].sum())) + 0.01
    # near side: the bar is now on the right, the foot at the top and dimmer
    assert psf[:, R // 2 + 12].sum() > 5 * psf[:, R // 2 - 12].sum()
    top = psf[:R // 2 - 10]
    assert 0.25 < top[top > 0].mean() / psf[R // 2 + 5:, R // 2 + 10][psf[R // 2 + 5:, R // 2 + 10] > 0].mean() < 0.6


def test_image_digest_is_part_of_the_configuration(tmp_path):
    img = np.full((16, 16), 255, np.uint8)
    path = tmp_path / "logo.png"
    Image.fromarray(img).save(path)
    table = {**BASE, "aperture": "image", "aperture_image": str(path)}
    cfg = from_table(StylizedConfig, table, "s.toml [psf.stylized]")
    assert len(cfg.aperture_image_sha256) == 64
    assert from_table(StylizedConfig, to_table(cfg), "round trip") == cfg
    img[0, 0] = 0
    Image.fromarray(img).save(path)
    changed = from_table(StylizedConfig, table, "s.toml [psf.stylized]")
    assert to_table(changed) != to_table(cfg)  # so the content hash changes
    with pytest.raises(UserError, match="the image changed"):
        from_table(StylizedConfig, to_table(cfg), "s.toml [psf.stylized]")


def test_last_cell_fits_the_minimum_resolution():
    need = min_psf_resolution(26.0 * 1.2)
    m = load_model("stylized", {**BASE, "psf_resolution": need, "channel_scale": [1.2, 1.0, 0.8],
                                "aperture": "circle"})
    res = m.trace_cell(m.grid.size - 1)
    assert res.n_outside == 0 and res.psf[:2].sum() == 0
    assert np.allclose(res.psf.astype(np.float64).sum(axis=(0, 1)), 1.0, atol=1e-6)
    assert m.rays_for_cell(m.grid.size - 1) % m.config.rays_per_launch == 0


@pytest.mark.parametrize("table, match", [
    ({"psf_resolution": 61, "channel_scale": [1.5, 1.0, 1.0]}, r"psf_resolution >= 83"),
    ({"channel_scale": [1.0, 0.9]}, "channel_scale"),
    ({"channel_scale": [1.0, -0.9, 1.0]}, "channel_scale = -0.9"),
    ({"aperture": "image", "aperture_image": "/nonexistent/logo.png"}, "logo.png: no such file"),
    ({"aperture": "image"}, "needs aperture_image"),
    ({"aperture": "star", "aperture_blades": 5}, "does not use"),
    ({"max_coc_px": 0.0}, "max_coc_px"),
    ({"beta": 0.0}, "beta"),
    ({"colour_scale": [1, 1, 1]}, r"unknown key\(s\) \['colour_scale'\]"),
])
def test_bad_config_is_a_user_error_before_tracing(table, match):
    with pytest.raises(UserError, match=match) as info:
        load_model("stylized", {**BASE, **table}, "scene.toml [psf.stylized]")
    assert "scene.toml [psf.stylized]" in str(info.value)


def test_unreadable_image_file(tmp_path):
    bad = tmp_path / "logo.png"
    bad.write_text("this is not an image")
    with pytest.raises(UserError, match=r"logo\.png.*cannot be read"):
        load_model("stylized", {**BASE, "aperture": "image", "aperture_image": str(bad)})
