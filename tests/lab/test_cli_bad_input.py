"""Issue 14's bad inputs, tried as a user would: each exits 2 with one line naming the thing, the
bad value and the fix, and leaves nothing behind (no output, no temporary file, no folder, the
inputs untouched)."""
import json
import os
import subprocess
import sys

import numpy as np
import OpenEXR
import pytest

from lab.cli import main
from lab.exr_io import LabelledImage, write_labelled
from lab.paths import ROOT, SCENES
from runtime_cl.psf.database import _checksum, _header_bytes
from runtime_cl.psf.synthetic import disc_database

THIN = {"lens": "thin", "focal_length_mm": 50.0, "f_number": 2.0, "focus_distance_m": 3.0,
        "sensor_width_mm": 36.0, "shutter": [0.0, 1.0]}
TINY = (SCENES / "tiny.toml").read_text()


def snapshot(*roots) -> dict:
    """Every file and folder under ``roots`` with its bytes (None for folders)."""
    out = {}
    for root in roots:
        for dirpath, dirs, files in os.walk(root):
            out[dirpath] = None
            for f in files:
                p = os.path.join(dirpath, f)
                out[p] = open(p, "rb").read() if os.path.isfile(p) else "special"
    return out


@pytest.fixture
def work(tmp_path, monkeypatch):
    """A folder with a small labelled EXR (in.exr) and a matching database (db.spdb); a private cache."""
    monkeypatch.setenv("SPLATLAB_CACHE", str(tmp_path / "cache"))
    rng = np.random.default_rng(0)
    z = rng.uniform(1, 9, (12, 12)).astype(np.float32)
    write_labelled(tmp_path / "in.exr", LabelledImage(rng.random((12, 12, 3), dtype=np.float32),
                                                      np.ones((12, 12), np.float32), z, dict(THIN)))
    disc_database(6.0, samples=6).save(tmp_path / "db.spdb")
    return tmp_path


def fails_cleanly(argv, capfd, work, *needles) -> str:
    """Run the CLI; assert exit 2, one line on stderr holding ``needles``, nothing changed.

    ``capfd`` (not capsys): what OpenEXR's C++ code prints goes to the file descriptors."""
    before = snapshot(work)
    code = main([str(a) for a in argv])
    err = capfd.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, (code, err)
    assert snapshot(work) == before, "files were left behind or changed"
    for needle in needles:
        assert needle in err[0], (needle, err[0])
    return err[0]


def render(work, *extra, out=None):
    return ["render", work / "in.exr", "--db", work / "db.spdb", "--out", work / "o.exr" if out is None else out, *extra]


@pytest.mark.parametrize("out, needles", [
    ("{w}", ["--out", "is a folder", "name a file"]),
    ("{w}/db.spdb/x.exr", ["--out", "is a file, not a folder"]),
    ("", ["--out", "not a file name"]),
    ("{w}/in.exr", ["--out", "also this command's input", "in.exr"]),
    ("{w}/db.spdb", ["--out", "also this command's input", "db.spdb"]),
    ("/sys/x.exr", ["--out /sys/x.exr", "permission denied"]),      # sysfs: no new files, even as root
])
def test_render_bad_out(work, capfd, out, needles):
    fails_cleanly(render(work, out=out.format(w=work)), capfd, work, *needles)


def test_render_refuses_the_camera_file_as_out(work, capfd):
    (work / "cam.toml").write_text("[camera]\nmodel = \"thin\"\n")
    fails_cleanly(render(work, "--camera", work / "cam.toml", out=work / "cam.toml"), capfd, work,
                  "also this command's input")


def test_render_full_and_read_only_disks(work, capfd, monkeypatch):
    """ENOSPC and EROFS while writing: one line naming --out, the old file kept, no temp."""
    import errno

    import runtime_cl.atomic_file as atomic_file

    (work / "o.exr").write_bytes(b"old result")
    for code, needle in ((errno.ENOSPC, "no space left"), (errno.EROFS, "read-only")):
        def refuse(src, dst, code=code):
            raise OSError(code, os.strerror(code))

        monkeypatch.setattr(atomic_file.os, "replace", refuse)
        fails_cleanly(render(work), capfd, work, "o.exr", needle)


@pytest.mark.parametrize("make, needles", [
    (lambda w: w / "missing.exr", ["missing.exr", "no such file"]),
    (lambda w: w, ["is a folder, not a file"]),
    (lambda w: (w / "t.exr").write_bytes((w / "in.exr").read_bytes()[:2000]) and w / "t.exr",
     ["not a readable OpenEXR file"]),
])
def test_render_bad_exr(work, capfd, make, needles):
    path = make(work)
    fails_cleanly(["render", path, "--db", work / "db.spdb", "--out", work / "o.exr"], capfd, work, *needles)


def exr_with(work, header=None, channels=None, name="bad.exr"):
    """in.exr re-written with changed header attributes and channels."""
    with OpenEXR.File(str(work / "in.exr"), separate_channels=True) as exr:
        hdr = dict(exr.header())
        chans = {k: c.pixels for k, c in exr.channels().items()}
    hdr.update(header or {})
    chans.update(channels or {})
    with OpenEXR.File(hdr, {k: v for k, v in chans.items() if v is not None}) as f:
        f.write(str(work / name))
    return work / name


@pytest.mark.parametrize("camera, needles", [
    (json.dumps(dict(THIN, focal_length_mm=True)), ["focal_length_mm = True", "finite number"]),
    ('{"lens": "thin", "focal_length_mm": ' + "9" * 400 + "}", ["400 digits"]),
    ("[" * 100000 + "]" * 100000, ["nested 100000 deep", "--camera"]),
    (json.dumps(dict(THIN, f_number=1e400)), ["Infinity at 'f_number'"]),
])
def test_render_bad_camera_header(work, capfd, camera, needles):
    path = exr_with(work, {"splatlab.camera": camera})
    fails_cleanly(["render", path, "--db", work / "db.spdb", "--out", work / "o.exr"], capfd, work,
                  "splatlab.camera", *needles)


def test_render_without_z_names_an_existing_command(work, capfd):
    path = exr_with(work, channels={"Z": None})
    msg = fails_cleanly(["render", path, "--db", work / "db.spdb", "--out", work / "o.exr"], capfd, work,
                        "without Z")
    assert "splatlab reference SCENE" in msg


def test_render_camera_file_not_utf8_or_a_folder(work, capfd):
    (work / "cam.toml").write_bytes(b'[camera]\nmodel = "th\xffin"\n')
    fails_cleanly(render(work, "--camera", work / "cam.toml"), capfd, work, "--camera file", "not UTF-8",
                  "line 2, column 12")
    fails_cleanly(render(work, "--camera", work), capfd, work, "--camera file", "is a folder")


@pytest.mark.parametrize("option, needles", [
    (["--directions", "0"], ["--directions 0", "[1, 8]"]),
    (["--directions", "99"], ["--directions 99", "[1, 8]"]),
    (["--edges", "2"], ["--edges 2", "[3, 256]"]),
    (["--edges", "100000"], ["--edges 100000", "[3, 256]"]),
])
def test_polygon_options_are_named_and_bounded(work, capfd, option, needles):
    fails_cleanly(["render", work / "in.exr", "--method", "polygon", *option, "--out", work / "o.exr"],
                  capfd, work, *needles)


def resaved(work, **header):
    """db.spdb with header entries replaced and a valid checksum (bad.spdb)."""
    with np.load(work / "db.spdb") as z:
        arrays = {k: z[k] for k in z.files}
    h = json.loads(bytes(arrays["header"]))
    h.update(header)
    hb = _header_bytes(h)
    arrays["header"] = np.frombuffer(hb, np.uint8)
    names = [k for k in arrays if k not in ("header", "checksum")]
    arrays["checksum"] = np.frombuffer(_checksum(hb, {n: arrays[n] for n in names}).encode(), np.uint8)
    with open(work / "bad.spdb", "wb") as fh:
        np.savez(fh, **arrays)
    return work / "bad.spdb"


@pytest.mark.parametrize("header, needles", [
    ({"params": [1, 2]}, ["params = [1, 2]", "JSON object"]),
    ({"stats": 7}, ["stats = 7", "list of names"]),
    ({"channels": True}, ["channels = True"]),
    ({"grid": {"n": 10 ** 15, "beta": [2], "ranges": [[0, 1]], "names": ["r"]}}, ["n = 1000000000000000"]),
])
def test_database_bad_header_types(work, capfd, header, needles):
    fails_cleanly(["db", "info", resaved(work, **header)], capfd, work, "spreadlet database", *needles)


def scene(work, old, new, name="s.toml", base=TINY):
    """``base`` (a scene file's text, default tiny.toml) with ``old`` replaced by ``new``, written to ``work``."""
    assert old in base
    (work / name).write_text(base.replace(old, new, 1))
    return work / name


@pytest.mark.parametrize("old, new, needles", [
    ("center = [0.12, 0.15, 2.05]", "center = [nan, 0.15, 2.05]", ["shapes #3.center[0] = nan", "finite"]),
    ("radius = 0.15", "radius = inf", ["shapes #3.radius = inf"]),
    ("position = [0.13, 0.5, 0.0]", "position = [nan, 0.5, 0.0]", ["camera.position[0] = nan"]),
    ("look_at = [0.1, 0.35, 2.0]", "look_at = [0.1, inf, 2.0]", ["camera.look_at[1] = inf"]),
    ("[psf.simple_lens]", "[psf.simple_lens]\nmax_coc_px = nan", ["psf.simple_lens.max_coc_px = nan"]),
    ("resolution = [64, 64]", "resolution = [100000, 100000]", ["resolution = [100000, 100000]", "at most 16384"]),
    ("reference_spp = 256", "reference_spp = 100000000000", ["reference_spp", "at most"]),
    ('name = "tiny"', 'name = "../x"', ["name = '../x'", "folder name"]),
    ('name = "tiny"', 'name = ""', ["name = ''"]),
    ('name = "tiny"', 'name = "a\\u0000b"', ["name = 'a\\x00b'"]),
    ('name = "tiny"', 'name = "a/b"', ["name = 'a/b'"]),
])
def test_scene_values(work, capfd, old, new, needles):
    fails_cleanly(["plan", scene(work, old, new)], capfd, work, "s.toml", *needles)


def test_scene_not_utf8_or_a_folder(work, capfd):
    (work / "s.toml").write_bytes(TINY.encode().replace(b'"tiny"', b'"ti\xffny"'))
    fails_cleanly(["plan", work / "s.toml"], capfd, work, "scene file", "not UTF-8", "save it as UTF-8")
    fails_cleanly(["plan", work], capfd, work, "scene file", "is a folder")


@pytest.mark.parametrize("argv", [
    ["plan", "{fifo}"],
    ["render", "{w}/in.exr", "--db", "{w}/db.spdb", "--camera", "{fifo}", "--out", "{w}/o.exr"],
    ["render", "{w}/in.exr", "--db", "{fifo}", "--out", "{w}/o.exr"],
    ["render", "{fifo}", "--db", "{w}/db.spdb", "--out", "{w}/o.exr"],
])
def test_a_fifo_is_refused_without_blocking(work, argv):
    fifo = work / "pipe.toml"
    os.mkfifo(fifo)
    argv = [a.format(w=work, fifo=fifo) for a in argv]
    p = subprocess.run([sys.executable, "-m", "lab.cli", *argv], cwd=ROOT, capture_output=True, text=True,
                       timeout=120, env=dict(os.environ, SPLATLAB_CACHE=str(work / "cache")))
    err = p.stderr.strip().splitlines()
    assert p.returncode == 2 and len(err) == 1 and "FIFO" in err[0], (p.returncode, err)


def test_precompute_out_checked_before_any_work(work, capfd):
    sets = ["--set", "max_coc_px=6", "--set", "samples=4", "--set", "psf_resolution=17"]
    fails_cleanly(["precompute", "simple_lens", *sets, "--out", work], capfd, work, "--out", "is a folder")
    fails_cleanly(["precompute", "simple_lens", *sets, "--out", work / "in.exr" / "x.spdb"], capfd, work,
                  "is a file, not a folder")
    assert not (work / "cache").exists()   # nothing was traced


@pytest.mark.parametrize("sets, needles", [
    (["psf_resolution=10000000000"], ["psf_resolution = 10000000000", "at most 16383"]),
    (["psf_resolution=1e10"], ["psf_resolution = 10000000000.0", "integer"]),
    (["samples=100000000000000"], ["samples = 100000000000000", "at most 65536"]),
    (["rays_per_psf=1" + "0" * 400], ["rays_per_psf", "at most"]),
    (["basis=haar"], ["basis = 'haar'", "['laplacian', 'rows']"]),
])
def test_precompute_sizes_are_bounded(work, capfd, sets, needles):
    argv = ["precompute", "simple_lens", "--set", "max_coc_px=6"] + [a for s in sets for a in ("--set", s)]
    fails_cleanly(argv, capfd, work, *needles)


def test_a_model_whose_psfs_turn_takes_no_row_basis(work, capfd):
    """combined turns its PSFs by the motion angle: row differences alone cannot turn, so its
    bases are "dual" (both) and "laplacian"; physical_lens has no ``basis`` key at all."""
    fails_cleanly(["precompute", "combined", "--set", "max_coc_px=6", "--set", "max_motion_px=4",
                   "--set", "basis=rows"], capfd, work, "basis = 'rows'", "['dual', 'laplacian']")
    fails_cleanly(["precompute", "physical_lens", "--set", "basis=rows"], capfd, work,
                  "unknown key(s) ['basis']")


def test_reference_and_report_check_their_folder_first(work, capfd):
    path = scene(work, "seed = 7", "seed = 8")
    fails_cleanly(["reference", path, "--out-dir", work / "in.exr"], capfd, work, "--out-dir", "is a file")
    fails_cleanly(["report", path, "--out-dir", work / "in.exr"], capfd, work, "--out-dir", "is a file")
    assert not (work / "cache").exists()   # nothing was rendered


def test_report_refuses_to_overwrite_its_baseline(work, capfd):
    path = scene(work, "seed = 7", "seed = 8")
    (work / "r").mkdir()
    (work / "r" / "report.json").write_text('{"methods": {}}')
    fails_cleanly(["report", path, "--out-dir", work / "r", "--baseline", work / "r" / "report.json"],
                  capfd, work, "also this command's input")


def test_baseline_not_utf8_or_a_folder(work, capfd):
    path = scene(work, "seed = 7", "seed = 8")
    (work / "b.json").write_bytes(b"\xff\xfe{")
    fails_cleanly(["report", path, "--baseline", work / "b.json"], capfd, work, "--baseline", "not UTF-8")
    fails_cleanly(["report", path, "--baseline", work], capfd, work, "--baseline", "is a folder")


@pytest.mark.parametrize("command", ["plan", "precompute", "reference", "report"])
def test_a_bad_psf_setting_fails_before_any_render(work, capfd, command):
    """``max_coc_px = -3`` is blamed on max_coc_px (not the psf_resolution derived from it), before
    the input and reference renders (the table does not need the input: it gives max_coc_px)."""
    path = scene(work, "[psf.simple_lens]", "[psf.simple_lens]\nmax_coc_px = -3")
    fails_cleanly([command, path], capfd, work, "[psf.simple_lens]: max_coc_px = -3.0: must be a finite number > 0")
    assert not (work / "cache").exists()


def test_report_knobs_unknown_or_without_sweep(work, capfd):
    path = scene(work, "seed = 7", "seed = 8")
    fails_cleanly(["report", path, "--sweep", "--knobs", "lens_rays,nope"], capfd, work, "--knobs", "nope",
                  "operating_point")
    fails_cleanly(["report", path, "--knobs", "lens_rays"], capfd, work, "--knobs", "add --sweep")
    assert not (work / "cache").exists()   # refused before any render


@pytest.mark.parametrize("method", ["spreadlets", "splat", "filter"])
def test_spreadlet_layers_zero(work, capfd, method):
    fails_cleanly(["render", work / "in.exr", "--db", work / "db.spdb", "--method", method, "--layers", "0",
                   "--out", work / "o.exr"], capfd, work, "--layers 0", ">= 1")


def test_bad_guard_band_header(work, capfd):
    path = exr_with(work, {"splatlab.guard_px": "6"})
    fails_cleanly(["render", path, "--db", work / "db.spdb", "--out", work / "o.exr"], capfd, work,
                  "bad.exr", "splatlab.guard_px = '6'", "narrower than half")


@pytest.mark.parametrize("new, needles", [
    ("seed = 7\nguard_band = 3", ["guard_band = 3", "true or false"]),
    ("seed = 7\ndepth_layers = 0", ["depth_layers = 0", "between 1 and 16"]),
])
def test_layer_and_guard_scene_keys(work, capfd, new, needles):
    fails_cleanly(["plan", scene(work, "seed = 7", new)], capfd, work, "s.toml", *needles)


FOGBOX = (SCENES / "tiny_fogbox.toml").read_text()
BOX = "box = { center = [-0.6, 0.9, 2.75], size = [1.4, 1.2, 1.5] }"


@pytest.mark.parametrize("new, needles", [
    ("box = { center = [-0.6, 0.9, 2.75], size = [1.4, 0.0, 1.5] }", ["[medium]: box: size = [1.4, 0.0, 1.5]", "> 0"]),
    ("box = { center = [-0.6, 0.9, 2.75], size = [1.4, -1.2, 1.5] }", ["[medium]: box: size = [1.4, -1.2, 1.5]", "> 0"]),
    ("box = { center = [nan, 0.9, 2.75], size = [1.4, 1.2, 1.5] }", ["medium.box.center[0] = nan"]),
    ("box = { center = [-0.6, 0.9, 2.75], size = [1.4, inf, 1.5] }", ["medium.box.size[1] = inf"]),
    ("box = { center = [-0.6, 0.9], size = [1.4, 1.2, 1.5] }", ["[medium]", "center", "3 entries"]),
    ("box = { center = [-0.6, 0.9, 2.75], size = [1.4, 1.2, 1.5], rotate = [0, 1, 0] }", ["[medium]", "unknown key",
                                                                                        "rotate"]),
    ("box = [1, 2, 3]", ["[medium]", "box", "must be a table"]),
    # the floor (y = 0) crosses a box reaching below it: Mitsuba would give it the medium on one side only
    ("box = { center = [-0.6, 0.2, 2.75], size = [1.4, 1.2, 1.5] }", ["[[shapes]] #1 (rectangle)", "crosses the wall"]),
])
def test_medium_box_values(work, capfd, new, needles):
    assert BOX in FOGBOX
    (work / "s.toml").write_text(FOGBOX.replace(BOX, new, 1))
    fails_cleanly(["plan", work / "s.toml"], capfd, work, "s.toml", *needles)


@pytest.mark.parametrize("new, needles", [
    ("seed = 7\nreference_adaptive = 5", ["reference_adaptive = 5", "must be a table"]),
    ("seed = 7\nreference_adaptive = { tiles = 4 }", ["reference_adaptive", "missing key(s) ['extra_spp']"]),
    ("seed = 7\nreference_adaptive = { extra_spp = 0 }", ["reference_adaptive.extra_spp = 0", "between 1 and"]),
    ("seed = 7\nreference_adaptive = { extra_spp = 64, tile_px = 2 }", ["tile_px = 2", "between 8 and 4096"]),
    ("seed = 7\nreference_adaptive = { extra_spp = 64, pilot_spp = 4 }", ["pilot_spp = 4", "between 8"]),
    ("seed = 7\nreference_adaptive = { extra_spp = 64, tiles = 1.5 }", ["tiles = 1.5", "integer"]),
    ("seed = 7\nreference_adaptive = { extra_spp = 64, tile = 8 }", ["unknown key(s) ['tile']", "tile_px"]),
])
def test_adaptive_reference_keys(work, capfd, new, needles):
    fails_cleanly(["plan", scene(work, "seed = 7", new)], capfd, work, "s.toml", "[render]", *needles)


def test_sweep_needs_the_noise_floor(work, capfd):
    fails_cleanly(["report", scene(work, "seed = 7", "seed = 7"), "--sweep", "--no-noise-floor",
                   "--out-dir", work / "out"], capfd, work, "--sweep --no-noise-floor", "drop --no-noise-floor")


def test_bench_pass_options_are_checked_before_any_work(work, capfd):
    """``bench runtime --set``: an option no pass of the plan takes is refused, naming the options
    they take, before an input is rendered; other benches take no pass options."""
    fails_cleanly(["bench", "runtime", "--scene", SCENES / "tiny.toml", "--no-build", "--set", "bogus=1"], capfd,
                  work, "--set bogus=1", "spreadlet_rotation")
    fails_cleanly(["bench", "precompute", "--set", "spreadlet_rotation=bank"], capfd, work,
                  "not `bench precompute`")
    fails_cleanly(["report", SCENES / "tiny.toml", "--set", "bogus=1", "--out-dir", work / "out"], capfd, work,
                  "--set bogus=1", "spreadlet_rotation")


FOG = (SCENES / "tiny_fog.toml").read_text()


@pytest.mark.parametrize("old, new, needles", [
    ("sigma_t = 0.25", "sigma_t = -0.25", ["sigma_t = -0.25"]),
    ("g = 0.6", "g = 1.0", ["g = 1.0", "(-1, 1)"]),
    ("g = 0.6", "g = -1.5", ["g = -1.5", "(-1, 1)"]),
    ("albedo = [0.9, 0.9, 0.85]", "albedo = [0.9, 1.2, 0.85]", ["albedo", "1.2"]),
])
def test_medium_values(work, capfd, old, new, needles):
    """A bad [medium] is refused by `splatlab plan` in one line, before anything is traced."""
    fails_cleanly(["plan", scene(work, old, new, base=FOG)], capfd, work, "s.toml", "[medium]", *needles)


@pytest.mark.parametrize("content, needles", [
    (b"", ["cannot be read (an empty file)", "give the path of a PNG"]),
    ("black", ["has no open pixel"]),
    ("red", ["has colour", "save it as a grayscale PNG"]),
])
def test_aperture_image_files(work, capfd, content, needles):
    """An aperture PNG that is empty, all dark or coloured: `splatlab plan` exits 2 naming the file."""
    from PIL import Image

    png = work / "ap.png"
    if isinstance(content, bytes):
        png.write_bytes(content)
    else:
        rgb = np.zeros((8, 8, 3), np.uint8)
        if content == "red":
            rgb[2:6, 2:6] = (255, 0, 0)
        Image.fromarray(rgb, "RGB").save(png)
    old = '\naperture = { shape = "heart" }'   # the [camera] key, not the header comment's words
    path = scene(work, old, f'\naperture = {{ shape = "image", path = "{png}" }}',
                 base=(SCENES / "tiny_heart.toml").read_text())
    fails_cleanly(["plan", path], capfd, work, "ap.png", *needles)


@pytest.mark.parametrize("channels, needles", [
    ({"motion.X": np.ones((12, 12), np.float32)}, ["channel motion.X without its partner", "motion.Y"]),
    ({"motion.X": np.full((12, 12), np.nan, np.float32), "motion.Y": np.zeros((12, 12), np.float32)},
     ["144 pixel(s) of motion.X are NaN or infinite", "finite motion"]),
])
def test_render_bad_motion_vectors(work, capfd, channels, needles):
    """Motion vectors of the wrong shape (one component) or not finite: exit 2 naming the channel."""
    path = exr_with(work, channels=channels)
    fails_cleanly(["render", path, "--db", work / "db.spdb", "--out", work / "o.exr"], capfd, work, "bad.exr",
                  *needles)


RAIN = (SCENES / "tiny_rain.toml").read_text()
RAIN_LENS = '[100.0, 14.0, "N-BK7", 25.0],\n            [-100.0, 0.0, "air", 25.0]]'


@pytest.mark.parametrize("lens, needles", [
    # the caps cut through each other: 1 mm of glass between spheres whose sag at 25 mm is ~3 mm each
    ('[100.0, 1.0, "N-BK7", 25.0],\n            [-100.0, 0.0, "air", 25.0]]', ["intersect", "raise thickness_mm"]),
    # a diverging element: no real image, so no ray reaches a sensor
    ('[-100.0, 14.0, "N-BK7", 25.0],\n            [100.0, 0.0, "air", 25.0]]', ["no ray reaches a sensor",
                                                                             "converging"]),
    ('[100.0, 14.0, "BK7", 25.0],\n            [-100.0, 0.0, "air", 25.0]]', ["glass = 'BK7' is not in the catalog"]),
])
def test_thick_lens_prescriptions(work, capfd, lens, needles):
    """A prescription whose surfaces intersect, that forms no image, or names an unknown glass:
    `splatlab plan` exits 2 naming the scene, the surfaces and the fix."""
    fails_cleanly(["plan", scene(work, RAIN_LENS, lens, base=RAIN)], capfd, work, "s.toml", "[camera]", "surfaces",
                  *needles)
