"""The layered bench's time at equal quality: interpolation in log time, and its bounds."""
import math

import pytest

from lab.bench.layered_plot import equal_quality_speedup, plot_layered, ssim_at_time

MITSUBA = {1: {"ssim": 0.5, "time_ms": 100.0}, 4: {"ssim": 0.7, "time_ms": 400.0},
           16: {"ssim": 0.9, "time_ms": 1600.0}}


def test_speedup_interpolates_in_log_time():
    got = equal_quality_speedup(0.8, 10.0, MITSUBA)        # halfway from 400 to 1600 ms in log time: 800
    assert got["bound"] == "exact" and got["mitsuba_ms"] == pytest.approx(800.0)
    assert got["speedup"] == pytest.approx(80.0)
    assert equal_quality_speedup(0.7, 10.0, MITSUBA)["mitsuba_ms"] == pytest.approx(400.0)


def test_speedup_beyond_mitsubas_points_is_a_bound():
    low = equal_quality_speedup(0.95, 10.0, MITSUBA)
    assert low["bound"] == "lower" and low["speedup"] == pytest.approx(160.0)
    high = equal_quality_speedup(0.3, 10.0, MITSUBA)
    assert high["bound"] == "upper" and high["speedup"] == pytest.approx(10.0)


def test_ssim_at_equal_time_interpolates_in_log_time_and_marks_the_ends():
    curve = [(100.0, 0.9), (400.0, 0.96)]
    assert ssim_at_time(200.0, curve) == {"ssim": pytest.approx(0.93), "time_ms": 200.0, "bound": "exact"}
    assert ssim_at_time(50.0, curve)["bound"] == "faster" and ssim_at_time(50.0, curve)["ssim"] == 0.9
    assert ssim_at_time(900.0, curve)["bound"] == "slower" and ssim_at_time(900.0, curve)["ssim"] == 0.96


def test_plot_is_written(tmp_path):
    data = {"scene": "scenes/x.toml", "resolution": [8, 6], "input_layers": 3, "pinhole_input": {"ssim": 0.4},
            "methods": {f"peeled_{n}": {"rays": n, "ssim": 0.6 + 0.01 * math.log2(n), "time_ms": 2.0 * n}
                        for n in (8, 32)},
            "mitsuba_low_spp": {str(k): v for k, v in MITSUBA.items()},
            "equal_time": {"spreadlets_2": {"time_ms": 20.0, "ssim": 0.62}}}
    path = plot_layered(data, tmp_path / "layered.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 10_000
