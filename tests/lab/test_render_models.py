"""``splatlab render`` with a database of a model that turns its PSFs: ``combined`` reads the
labelled image's motion channels."""
import numpy as np
import pytest

from lab.cli import main
from lab.exr_io import LabelledImage, read_rgb, write_labelled
from runtime_cl.psf.database import DatabaseBuilder
from runtime_cl.coords.maps import psf_coords
from runtime_cl.psf.grid import NestedGrid
from runtime_cl.spreadlets.renderer import Renderer
from runtime_cl.camera.thin_lens import ThinLens

CAMERA = {"lens": "thin", "focal_length_mm": 50.0, "f_number": 2.0, "focus_distance_m": 2.0,
          "sensor_width_mm": 36.0}


@pytest.fixture(scope="module")
def combined_db(tmp_path_factory):
    """Every cell: a 9-pixel streak along +x with a brighter +x end (traced at 0 degrees)."""
    grid = NestedGrid.for_samples(4, (2.0, 1.0), ((0.0, 10.0), (0.0, 12.0)), ("coc_radius_px", "motion_px"))
    b = DatabaseBuilder("combined", {"config": {"motion_direction_deg": 0.0},
                                     "symmetries": ["motion_direction", "coc_sign"]}, grid, 1, 9)
    dense = np.zeros((9, 9))
    dense[4] = np.linspace(1.0, 2.0, 9)
    dense /= dense.sum()
    for _ in range(grid.size):
        b.add(np.zeros((0, 2), int), np.zeros(0), dense, fast_track=True,
              stats={"sparsity": 1.0, "ssim": 1.0, "l1": 0.0})
    path = tmp_path_factory.mktemp("db") / "combined.spdb"
    b.build().save(path)
    return path


def labelled(tmp_path, motion: dict):
    rng = np.random.default_rng(0)
    h, w = 12, 16
    depth = np.where(np.arange(w)[None, :] < 8, 1.9, 2.1) * np.ones((h, 1))  # in front | behind
    image = LabelledImage(rgb=rng.random((h, w, 3)).astype(np.float32), alpha=np.ones((h, w), np.float32),
                          depth=depth.astype(np.float32), camera=CAMERA, extra=motion)
    path = tmp_path / "in.exr"
    write_labelled(path, image)
    return path, image


def test_render_reads_the_motion_channels(combined_db, tmp_path, capsys):
    h, w = 12, 16
    mx = np.full((h, w), 3.0, np.float32)
    my = np.tile(np.linspace(-4, 4, w, dtype=np.float32), (h, 1))
    path, image = labelled(tmp_path, {"motion.X": mx, "motion.Y": my})
    out = tmp_path / "out.exr"
    assert main(["render", str(path), "--db", str(combined_db), "--method", "splat", "--out", str(out)]) == 0
    assert "splat" in capsys.readouterr().out
    from runtime_cl.psf.database import SpreadletDatabase

    db = SpreadletDatabase.load(combined_db)
    pc = psf_coords(ThinLens.from_json(CAMERA), image.depth, db, np.stack([mx, my], axis=-1))
    want, _ = Renderer(db).render(image.rgb, pc.coords, "splat", angle=pc.angle)
    np.testing.assert_array_equal(read_rgb(out), want)
    still, _ = Renderer(db).render(image.rgb, pc.coords, "splat")
    assert not np.allclose(want, still)  # the streaks were turned


def test_render_names_a_missing_motion_channel(combined_db, tmp_path, capsys):
    path, _ = labelled(tmp_path, {"motion.X": np.zeros((12, 16), np.float32)})
    out = tmp_path / "out.exr"
    assert main(["render", str(path), "--db", str(combined_db), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1
    assert str(path) in err and "motion.X without its partner" in err and "motion.Y" in err
    assert not out.exists()
