"""Fuzzing the labelled-pixel EXR reader: header, channel and byte mutations of a small labelled
EXR give an image or a UserError, never another exception, a hang or a file left behind.

Seeded (derandomize) and bounded (examples, deadline); ``-m slow`` runs 10 000 cases of each.
"""
import json
import os
import struct
import tempfile

import numpy as np
import OpenEXR
import pytest
from fuzz_support import FAST, SLOW, read_mutated
from hypothesis import given
from hypothesis import strategies as st

from lab.errors import UserError
from lab.exr_io import LabelledImage, read_labelled, write_labelled

THIN = {"lens": "thin", "focal_length_mm": 50.0, "f_number": 2.0, "focus_distance_m": 3.0,
        "sensor_width_mm": 36.0, "shutter": [0.0, 1.0]}
H = W = 6


def _channels() -> dict:
    rng = np.random.default_rng(5)
    out = {c: rng.random((H, W), dtype=np.float32) for c in ("R", "G", "B", "A", "motion.X", "motion.Y")}
    out["Z"] = rng.uniform(1, 9, (H, W)).astype(np.float32)
    for k in range(2):
        for c in "RGB":
            out[f"layer{k}.{c}"] = rng.random((H, W), dtype=np.float32)
        out[f"layer{k}.A"] = np.full((H, W), 0.5, np.float32)
        out[f"layer{k}.Z"] = np.full((H, W), 2.0 + k, np.float32)
    return out


CHANNELS = _channels()
HEADER = {"splatlab.camera": json.dumps(THIN), "splatlab.format": "labelled-pixels/1"}


def _write(path, header, channels):
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **header}
    with OpenEXR.File(hdr, dict(channels)) as f:    # a copy: OpenEXR turns the dict's arrays into Channels
        f.write(str(path))


def _bytes(header, channels) -> bytes:
    with tempfile.TemporaryDirectory() as d:
        _write(os.path.join(d, "x.exr"), header, channels)
        with open(os.path.join(d, "x.exr"), "rb") as fh:
            return fh.read()


GOOD = _bytes(HEADER, CHANNELS)

JSON = st.recursive(st.none() | st.booleans() | st.floats(allow_nan=False) | st.integers(-2 ** 70, 2 ** 70)
                    | st.text(max_size=6) | st.sampled_from(["thin", "thick", "pinhole", "lens"]),
                    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(
                        st.sampled_from(list(THIN) + ["aperture", "medium", "surfaces", "fov_deg"]), inner, max_size=4),
                    max_leaves=12)
PIXELS = st.sampled_from([np.nan, np.inf, -np.inf, -1.0, 0.0, 1e30, 2.0])


@st.composite
def camera_text(draw):
    kind = draw(st.sampled_from(["value", "field", "raw"]))
    if kind == "value":
        return json.dumps(draw(JSON))
    if kind == "field":
        cam = dict(THIN)
        cam[draw(st.sampled_from(sorted(cam) + ["aperture", "medium"]))] = draw(JSON)
        return json.dumps(cam)
    return draw(st.sampled_from(["[" * 5000, "{", '{"lens": "thin"' + ", " * 3, "9" * 500, "NaN", "caf\u00e9\x00"]))


@st.composite
def mutated_file(draw):
    """(bytes of an EXR, what was done)."""
    header, channels = dict(HEADER), dict(CHANNELS)
    ops = draw(st.lists(st.sampled_from(["camera", "nocamera", "format", "drop", "rename", "add", "pixel",
                                         "dtype", "subsample", "truncate", "flip"]), min_size=1, max_size=3))
    for op in ops:
        if op == "camera":
            header["splatlab.camera"] = draw(camera_text())
        elif op == "nocamera":
            header.pop("splatlab.camera", None)
        elif op == "format":
            header["splatlab.format"] = draw(st.sampled_from(["labelled-pixels/2", "", "x" * 300]))
        elif op == "drop" and len(channels) > 1:
            del channels[draw(st.sampled_from(sorted(channels)))]
        elif op == "rename" and channels:
            old = draw(st.sampled_from(sorted(channels)))
            channels[draw(st.sampled_from(["layer", "layer7.R", "layer0.Q", "layer-1.Z", "layerx.R", "motion.Z",
                                           "Z", "layer2.A", "layer00.R", "R"]))] = channels.pop(old)
        elif op == "add":
            channels[draw(st.sampled_from(["layer2.R", "layer3.Z", "lens.U", "time", "motion.X"]))] = \
                np.full((H, W), draw(PIXELS), np.float32)
        elif op == "pixel" and channels:
            name = draw(st.sampled_from(sorted(channels)))
            ch = channels[name].astype(np.float32)
            ch[draw(st.integers(0, H - 1)), draw(st.integers(0, W - 1))] = draw(PIXELS)
            channels[name] = ch
        elif op == "dtype" and channels:
            name = draw(st.sampled_from(sorted(channels)))
            with np.errstate(all="ignore"):   # out-of-range values are part of the mutation
                channels[name] = channels[name].astype(draw(st.sampled_from([np.float16, np.uint32])))
    data = bytearray(_bytes(header, channels))
    for op in ops:
        if op == "subsample":                          # x/y sampling of one channel in the header's chlist
            name = draw(st.sampled_from(sorted(channels))).encode() + b"\0"
            at = data.find(name)
            if at >= 0:   # after the name: pixel type (4 bytes), pLinear + 3 reserved, xSampling, ySampling
                data[at + len(name) + 8:at + len(name) + 16] = struct.pack("<ii", draw(st.integers(0, 3)),
                                                                           draw(st.integers(0, 3)))
        elif op == "truncate" and data:
            del data[draw(st.integers(0, len(data) - 1)):]
        elif op == "flip" and data:
            for _ in range(draw(st.integers(1, 4))):
                data[draw(st.integers(0, len(data) - 1))] ^= draw(st.integers(1, 255))
    return bytes(data), ops


def _read(path):
    image = read_labelled(path)
    assert isinstance(image, LabelledImage)
    return image.layers(path)


def check(data: bytes):
    read_mutated(data, "in.exr", _read, UserError)


def test_the_unmutated_file_reads():
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "in.exr")
        with open(path, "wb") as fh:
            fh.write(GOOD)
        image = read_labelled(path)
        assert len(image.layers()) == 2 and image.camera == THIN


def test_subsampled_layer_channels_are_named(tmp_path):
    """OpenEXR's writer refuses sub-sampling, so the header's chlist is patched (x/y sampling 2)."""
    data = bytearray(GOOD)
    for name in (b"layer0.R\0", b"layer0.Z\0"):
        at = data.index(name) + len(name)
        data[at + 8:at + 16] = struct.pack("<ii", 2, 2)
    (tmp_path / "in.exr").write_bytes(bytes(data))
    with pytest.raises(UserError, match=r"channel\(s\) \['layer0.R', 'layer0.Z'\] are sub-sampled \(x/y sampling "
                                        r"\[\(2, 2\)\]\); write every channel at full resolution"):
        read_labelled(tmp_path / "in.exr")


def test_written_image_round_trips_through_the_fuzzed_reader(tmp_path):
    im = read_labelled(_write(tmp_path / "a.exr", HEADER, CHANNELS) or tmp_path / "a.exr")
    write_labelled(tmp_path / "b.exr", im)
    check((tmp_path / "b.exr").read_bytes())


@FAST
@given(mutated_file())
def test_fuzz_exr(case):
    check(case[0])


@pytest.mark.slow
@SLOW
@given(mutated_file())
def test_fuzz_exr_10k(case):
    check(case[0])


def test_found_by_fuzzing_a_format_attribute_of_another_type(tmp_path):
    """10 000-case run: a flipped byte turned ``splatlab.format``'s type ``string`` into an unknown
    one, and printing that attribute raised UnicodeDecodeError."""
    data = bytearray(GOOD)
    at = data.index(b"splatlab.format\0") + len(b"splatlab.format\0")
    data[at] ^= 0x80
    (tmp_path / "in.exr").write_bytes(bytes(data))
    with pytest.raises(UserError, match=r"splatlab.format = an attribute of type"):
        read_labelled(tmp_path / "in.exr")
