"""The inset picker finds planted error blobs, never overlaps its windows, and writes the crops."""
import numpy as np
from PIL import Image

from lab.report.insets import hardest_windows, window_size, write_insets


def blob(shape, row, col, sigma, height=1.0):
    y, x = np.mgrid[:shape[0], :shape[1]]
    return height * np.exp(-((y - row) ** 2 + (x - col) ** 2) / (2 * sigma**2))


def test_finds_a_planted_blob_and_then_the_weaker_one():
    rng = np.random.default_rng(3)
    error = 0.05 * rng.random((96, 128)) + blob((96, 128), 70, 30, 3.0) + blob((96, 128), 20, 100, 3.0, 0.6)
    (r1, c1, m1), (r2, c2, m2), (r3, c3, m3) = hardest_windows(error, 12, k=3)
    assert r1 <= 70 < r1 + 12 and c1 <= 30 < c1 + 12          # the window holds the strong blob's centre
    assert r2 <= 20 < r2 + 12 and c2 <= 100 < c2 + 12         # then the weaker one
    assert m1 > m2 > m3
    for (ra, ca), (rb, cb) in [((r1, c1), (r2, c2)), ((r1, c1), (r3, c3)), ((r2, c2), (r3, c3))]:
        assert abs(ra - rb) >= 12 or abs(ca - cb) >= 12       # no two windows overlap


def test_stops_when_no_window_fits_without_overlap():
    assert len(hardest_windows(np.ones((16, 16)), 8, k=10)) == 4   # a 16 px square holds four 8 px windows
    assert window_size((64, 64)) == 12 and window_size((1024, 768)) == 96


def test_writes_side_by_side_crops(tmp_path):
    rng = np.random.default_rng(0)
    reference = rng.random((64, 64, 3)).astype(np.float32) * 0.5
    wrong = reference.copy()
    wrong[40:46, 10:16] += 0.4                                  # the method misses one patch
    info = write_insets(reference, {"spreadlets": wrong, "splat": reference * 1.0}, tmp_path, k=2)
    first = info["regions"][0]
    assert first["row"] <= 40 and first["row"] + 12 >= 46 and first["col"] <= 10 and first["col"] + 12 >= 16
    crop = np.asarray(Image.open(tmp_path / first["crops"]["spreadlets"]))
    assert crop.shape == (192, 192, 3)                          # 12 px at 16x nearest-neighbour zoom
    assert (crop[0:16, 0:16] == crop[0, 0]).all() and (crop[16:32, 0:16] == crop[16, 0]).all()   # blocks
    assert first["method_errors"]["spreadlets"] > 0 == first["method_errors"]["splat"]
    assert Image.open(tmp_path / "insets_overview.png").width >= 512
