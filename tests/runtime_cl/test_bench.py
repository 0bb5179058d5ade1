"""The throughput benchmark: a small run in the fast suite, the 1024^2 figure as a slow check."""
import pytest

from runtime_cl.bench import run


def test_small_benchmark_reports_rates():
    out = run(48, 40, spreadlets=20, r_max=8.0, channels=3, repeats=1)
    assert set(out["methods"]) == {"spreadlets", "splat", "filter"}
    sp = out["methods"]["spreadlets"]
    assert sp["spreadlets"] == 48 * 40 * 20  # every cell in the scene has exactly 20
    assert sp["M_spreadlets_per_s"] > 0
    assert out["methods"]["splat"]["M_dense_pixels_per_s"] > 0
    assert out["device"]["compute_units"] >= 1


@pytest.mark.slow
def test_spreadlet_throughput_at_1024():
    out = run(1024, 1024, spreadlets=50, methods=("spreadlets",), repeats=3)
    rate = out["methods"]["spreadlets"]["M_spreadlets_per_s"]
    print(f"spreadlets: {rate:.0f} M/s")
    # DESIGN.md: ~650 M/s on an idle 2-core machine; the floor leaves room for a busy neighbour
    assert rate > 150
