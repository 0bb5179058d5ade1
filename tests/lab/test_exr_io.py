"""Labelled-pixel and RGB EXR files: round trips, atomic writes, and every read error."""
import json

import numpy as np
import OpenEXR
import pytest

from lab.errors import UserError
from lab.exr_io import LabelledImage, read_labelled, read_rgb, write_labelled, write_rgb

THIN = {"lens": "thin", "focal_length_mm": 50.0, "f_number": 2.0, "focus_distance_m": 3.0,
        "sensor_width_mm": 36.0, "shutter": [0.0, 1.0]}


def image(h=6, w=7, seed=0):
    rng = np.random.default_rng(seed)
    z = rng.uniform(0.5, 20, (h, w)).astype(np.float32)
    z[0, 0] = np.inf  # background at infinity is valid
    return LabelledImage(rgb=rng.random((h, w, 3), dtype=np.float32), alpha=np.ones((h, w), np.float32),
                         depth=z, camera=dict(THIN), extra={"motion.X": rng.random((h, w), dtype=np.float32),
                                                           "motion.Y": rng.random((h, w), dtype=np.float32)})


def raw_exr(path, channels, header=None):
    """Write an EXR directly (bypassing write_labelled) to build broken inputs."""
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **(header or {})}
    with OpenEXR.File(hdr, channels) as f:
        f.write(str(path))


def test_round_trip(tmp_path):
    im = image()
    write_labelled(tmp_path / "sub" / "in.exr", im)
    back = read_labelled(tmp_path / "sub" / "in.exr")
    np.testing.assert_array_equal(back.rgb, im.rgb)
    np.testing.assert_array_equal(back.depth, im.depth)
    np.testing.assert_array_equal(back.extra["motion.X"], im.extra["motion.X"])
    assert back.camera == THIN and back.depth.dtype == np.float32
    assert [p.name for p in (tmp_path / "sub").iterdir()] == ["in.exr"]  # no temp files left


def test_rgb_round_trip_and_header(tmp_path):
    rgb = np.random.default_rng(1).random((5, 4, 3), dtype=np.float32)
    write_rgb(tmp_path / "ref.exr", rgb, {"splatlab.camera": json.dumps(THIN)})
    np.testing.assert_array_equal(read_rgb(tmp_path / "ref.exr"), rgb)
    assert json.loads(OpenEXR.File(str(tmp_path / "ref.exr")).header()["splatlab.camera"]) == THIN


def test_failed_write_keeps_old_file_and_no_temp(tmp_path, monkeypatch):
    path = tmp_path / "in.exr"
    write_labelled(path, image(seed=1))
    before = path.read_bytes()

    def boom(src, dst):
        raise OSError("disk full")

    import runtime_cl.atomic_file as atomic_file

    monkeypatch.setattr(atomic_file.os, "replace", boom)
    with pytest.raises(OSError):
        write_labelled(path, image(seed=2))
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["in.exr"]


def test_not_an_exr(tmp_path):
    (tmp_path / "x.exr").write_text("hello")
    with pytest.raises(UserError, match=r"x\.exr: not a readable OpenEXR file"):
        read_labelled(tmp_path / "x.exr")
    with pytest.raises(UserError, match="no such file"):
        read_labelled(tmp_path / "missing.exr")
    write_labelled(tmp_path / "t.exr", image())
    (tmp_path / "cut.exr").write_bytes((tmp_path / "t.exr").read_bytes()[:300])
    with pytest.raises(UserError, match="cut.exr: not a readable"):
        read_labelled(tmp_path / "cut.exr")


def test_exr_without_z(tmp_path):
    ones = np.ones((3, 3), np.float32)
    raw_exr(tmp_path / "noz.exr", {"R": ones, "G": ones, "B": ones, "A": ones},
            {"splatlab.camera": json.dumps(THIN)})
    with pytest.raises(UserError, match=r"noz\.exr: an EXR without Z .*'A', 'B', 'G', 'R'.*Z channel"):
        read_labelled(tmp_path / "noz.exr")
    raw_exr(tmp_path / "nob.exr", {"R": ones, "G": ones, "Z": ones})
    with pytest.raises(UserError, match=r"missing channel\(s\) \['B'\]"):
        read_labelled(tmp_path / "nob.exr")
    with pytest.raises(UserError, match=r"missing channel\(s\) \['B'\]"):
        read_rgb(tmp_path / "nob.exr")


@pytest.mark.parametrize("bad", [np.nan, 0.0, -2.0, -np.inf])
def test_bad_depth_count_and_first_pixel(tmp_path, bad):
    im = image()
    z = im.depth.copy()
    z[2, 3] = bad  # row 2, column 3 -> (x=3, y=2)
    z[4, 1] = bad
    write_labelled(tmp_path / "bad.exr", LabelledImage(im.rgb, im.alpha, z, im.camera))
    with pytest.raises(UserError) as exc:
        read_labelled(tmp_path / "bad.exr")
    msg = str(exc.value)
    assert "bad.exr: 2 pixel(s)" in msg and "(x=3, y=2)" in msg and "metres" in msg


def test_camera_header_missing_invalid_and_override(tmp_path):
    ones = np.ones((2, 2), np.float32)
    chans = {"R": ones, "G": ones, "B": ones, "Z": ones * 3}
    raw_exr(tmp_path / "nocam.exr", chans)
    with pytest.raises(UserError, match=r"no 'splatlab.camera' header.*--camera FILE.toml"):
        read_labelled(tmp_path / "nocam.exr")
    got = read_labelled(tmp_path / "nocam.exr", camera=THIN)  # the --camera override
    assert got.camera == THIN and np.all(got.alpha == 1)  # no A channel: full coverage
    raw_exr(tmp_path / "badjson.exr", chans, {"splatlab.camera": "{lens: thin"})
    with pytest.raises(UserError, match="not JSON"):
        read_labelled(tmp_path / "badjson.exr")
    raw_exr(tmp_path / "neg.exr", chans, {"splatlab.camera": json.dumps({**THIN, "f_number": -1})})
    with pytest.raises(UserError, match="f_number = -1"):
        read_labelled(tmp_path / "neg.exr")
    raw_exr(tmp_path / "odd.exr", chans, {"splatlab.camera": json.dumps({"lens": "fisheye"})})
    with pytest.raises(UserError, match="lens = 'fisheye' is not known"):
        read_labelled(tmp_path / "odd.exr")
    with pytest.raises(UserError, match="--camera override.*shutter"):
        read_labelled(tmp_path / "odd.exr", camera={**THIN, "shutter": [1, 0]})


def test_half_channels_are_read_as_float32(tmp_path):
    half = np.full((2, 3), 1.5, np.float16)
    raw_exr(tmp_path / "h.exr", {"R": half, "G": half, "B": half, "Z": half},
            {"splatlab.camera": json.dumps({"lens": "pinhole", "fov_x_deg": 40.0})})
    got = read_labelled(tmp_path / "h.exr")
    assert got.rgb.dtype == np.float32 and got.depth[0, 0] == 1.5


def test_foreign_format_version(tmp_path):
    ones = np.ones((2, 2), np.float32)
    raw_exr(tmp_path / "v.exr", {"R": ones, "G": ones, "B": ones, "Z": ones},
            {"splatlab.camera": json.dumps(THIN), "splatlab.format": "labelled-pixels/9"})
    with pytest.raises(UserError, match="labelled-pixels/9"):
        read_labelled(tmp_path / "v.exr")


def layered(h=5, w=6, n=2):
    """A labelled image with ``n`` layers: layer 0 a half-covered foreground, the last complete."""
    rng = np.random.default_rng(n)
    base = image(h, w)
    extra = {}
    for i in range(n):
        alpha = np.ones((h, w), np.float32) if i == n - 1 else (rng.random((h, w)) > 0.5).astype(np.float32)
        extra.update({f"layer{i}.R": rng.random((h, w), dtype=np.float32) * alpha,
                      f"layer{i}.G": rng.random((h, w), dtype=np.float32) * alpha,
                      f"layer{i}.B": rng.random((h, w), dtype=np.float32) * alpha, f"layer{i}.A": alpha,
                      f"layer{i}.Z": np.where(alpha > 0, 1.0 + 5 * i, np.inf).astype(np.float32)})
    return LabelledImage(base.rgb, base.alpha, base.depth, base.camera, extra)


def test_layers_round_trip(tmp_path):
    im = layered(n=3)
    write_labelled(tmp_path / "l.exr", im)
    back = read_labelled(tmp_path / "l.exr")
    layers = back.layers()
    assert len(layers) == 3
    np.testing.assert_array_equal(layers[1].rgb[..., 2], im.extra["layer1.B"])
    np.testing.assert_array_equal(layers[0].alpha, im.extra["layer0.A"])
    assert np.isinf(layers[0].depth[layers[0].alpha == 0]).all()
    assert image().layers() == []


@pytest.mark.parametrize("change,needles", [
    (lambda ch: ch.pop("layer1.Z"), ["layer 1 lacks", "'layer1.Z'", "layer1.R, .G, .B, .A"]),
    (lambda ch: [ch.update({k.replace("layer1", "layer2"): ch.pop(k)}) for k in list(ch) if k.startswith("layer1")],
     ["layers [0, 2]", "not [1]", "without gaps"]),
    (lambda ch: ch.update({"layer0.X": ch["layer0.R"]}), ["'layer0.X'", "layerN.<channel>", "layer0.R"]),
    (lambda ch: ch.update({"layerA.R": ch["layer0.R"]}), ["'layerA.R'", "layerN.<channel>"]),
    (lambda ch: ch["layer0.A"].__setitem__((0, 0), 1.5), ["layer0.A", "[0, 1]"]),
    (lambda ch: ch["layer1.Z"].__setitem__((0, 0), np.nan), ["layer1.Z", "NaN or non-positive"]),
])
def test_bad_layers_name_the_channel(tmp_path, change, needles):
    im = layered()
    channels = {"R": im.rgb[..., 0], "G": im.rgb[..., 1], "B": im.rgb[..., 2], "A": im.alpha, "Z": im.depth,
                **{k: v.copy() for k, v in im.extra.items()}}
    change(channels)
    raw_exr(tmp_path / "bad.exr", channels, {"splatlab.camera": json.dumps(THIN)})
    with pytest.raises(UserError) as exc:
        read_labelled(tmp_path / "bad.exr")
    msg = str(exc.value)
    assert "bad.exr" in msg and len(msg.splitlines()) == 1
    for needle in needles:
        assert needle in msg, msg


def test_header_iris_is_checked(tmp_path):
    bad = dict(THIN, aperture={"blades": 6, "rotaton_deg": 5})
    raw_exr(tmp_path / "iris.exr", {"R": image().rgb[..., 0], "G": image().rgb[..., 1], "B": image().rgb[..., 2],
                                    "Z": image().depth}, {"splatlab.camera": json.dumps(bad)})
    with pytest.raises(UserError, match=r"iris.exr header 'splatlab.camera' aperture: unknown key\(s\) \['rotaton_deg'\]"):
        read_labelled(tmp_path / "iris.exr")


def _channels(im):
    out = {c: im.rgb[..., i] for i, c in enumerate("RGB")}
    out.update(A=im.alpha, Z=im.depth, **im.extra)
    return out


@pytest.mark.parametrize("change, needle", [
    (lambda c: c.pop("motion.Y"), "motion.X without its partner"),
    (lambda c: c["motion.X"].__setitem__((2, 3), np.nan), "motion.X are NaN or infinite, first at (x=3, y=2)"),
])
def test_bad_motion_channels(tmp_path, change, needle):
    channels = {k: np.array(v) for k, v in _channels(image()).items()}
    change(channels)
    raw_exr(tmp_path / "m.exr", channels, {"splatlab.camera": json.dumps(THIN)})
    with pytest.raises(UserError) as err:
        read_labelled(tmp_path / "m.exr")
    assert needle in str(err.value) and str(tmp_path / "m.exr") in str(err.value)
