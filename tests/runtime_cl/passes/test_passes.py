"""The runtime pass registry, the one Timing contract and the public API (runtime_cl.render)."""
import time

import numpy as np
import pytest
from polygon_reference import shape

import runtime_cl
from runtime_cl.camera.thin_lens import ThinLens
from runtime_cl.coords.maps import psf_coords
from runtime_cl.errors import InputError
from runtime_cl.layers.composite import PixelLayer, render_layers
from runtime_cl.passes import RuntimePass, get_pass, pass_names
from runtime_cl.polygon.layers import PolygonLayerSplatter
from runtime_cl.polygon.splat import PolygonSplatter
from runtime_cl.psf.synthetic import disc_database
from runtime_cl.spreadlets.renderer import Renderer
from runtime_cl.timing import COLUMNS, MAX_RUNS, CallTimes, Timing, measure

CAMERA = ThinLens(focal_length_mm=50.0, f_number=2.0, focus_distance_m=0.5)


@pytest.fixture(scope="module")
def scene():
    rng = np.random.default_rng(3)
    h, w = 20, 28
    depth = np.where(np.arange(w)[None, :] < 14, 0.5, 0.3) * np.ones((h, 1))   # in focus | in front
    rgb = rng.random((h, w, 3)).astype(np.float32)
    db = disc_database(float(np.ceil(np.abs(CAMERA.coc_radius_px(depth, w)).max())) + 1, samples=10)
    return rgb, depth, db


def test_every_pass_declares_what_it_needs():
    names = pass_names()
    assert names[:4] == ["spreadlets", "splat", "filter", "polygon"] and "identity" in names
    for name in names:
        cls = get_pass(name)
        assert issubclass(cls, RuntimePass) and cls.name == name and cls.summary
        assert {"R", "G", "B"} <= set(cls.channels) and isinstance(cls.layered, bool)
        assert cls.database_models is None or isinstance(cls.database_models, tuple)
    assert runtime_cl.methods()["polygon"] == get_pass("polygon").summary
    with pytest.raises(InputError, match=r"method = 'bokeh'.*\['spreadlets', 'splat'"):
        get_pass("bokeh")


@pytest.mark.parametrize("method", ["spreadlets", "splat", "filter"])
def test_spreadlet_passes_are_the_renderer_bit_for_bit(scene, method):
    rgb, depth, db = scene
    got, timing = runtime_cl.render(rgb, depth, CAMERA, db, method=method)
    pc = psf_coords(CAMERA, depth, db)
    want, _ = Renderer(db).render(rgb, pc.coords, method, angle=pc.angle)
    np.testing.assert_array_equal(got, want)
    assert isinstance(timing, Timing) and timing.runs == 0 and timing.counts["pixels"] == rgb.shape[0] * rgb.shape[1]
    assert timing.device_ms > 0 and timing.time_ms >= timing.device_ms + timing.transfer_ms - 1e-9


def test_the_polygon_pass_is_the_splatter_bit_for_bit(scene):
    rgb, depth, _ = scene
    sp = PolygonSplatter(*shape("hexagon"))
    radius = np.abs(CAMERA.coc_radius_px(depth, depth.shape[1])).astype(np.float32)
    got, timing = runtime_cl.render(rgb, depth, CAMERA, method="polygon", aperture=sp)
    np.testing.assert_array_equal(got, sp.render(rgb, radius)[0])
    assert timing.counts["max_radius_px"] == float(radius.max())
    alpha = np.ones(depth.shape, np.float32)
    layered, timing = runtime_cl.render(rgb, depth, CAMERA, method="polygon", layers=3, aperture=sp,
                                        alpha=alpha)
    coc = CAMERA.coc_radius_px(depth, depth.shape[1]).astype(np.float32)
    want, info = render_layers(PolygonLayerSplatter(sp), PixelLayer(rgb, alpha, coc), 3)
    np.testing.assert_array_equal(layered, want)
    assert timing.counts["used_layers"] == len(info["layers"]) == 2 and timing.counts["depth_layers"] == 3


def test_a_pass_refuses_what_it_cannot_render(scene):
    rgb, depth, db = scene
    with pytest.raises(InputError, match=r"layers = 2: the 'identity' pass renders one layer.*\['spreadlets', "
                       r"'splat', 'filter', 'polygon', 'layered'"):
        runtime_cl.render(rgb, depth, CAMERA, method="identity", layers=2)
    with pytest.raises(InputError, match="needs a spreadlet database"):
        runtime_cl.render(rgb, depth, CAMERA, method="splat")
    with pytest.raises(InputError, match="uses no PSF database"):
        runtime_cl.render(rgb, depth, CAMERA, db, method="polygon")
    with pytest.raises(InputError, match=r"\['colour'\]: unknown option"):
        runtime_cl.render(rgb, depth, CAMERA, method="identity", colour=1)
    with pytest.raises(InputError, match="layered_input: the input has no layerN"):
        runtime_cl.render(rgb, depth, CAMERA, method="polygon", layers=2, layered_input=True,
                          aperture=PolygonSplatter(*shape("hexagon")))


def _timed_call(first_s, then_s, device_ms=1.0, transfer_ms=0.5):
    calls = []

    def call():
        time.sleep(first_s if not calls else then_s)
        calls.append(1)
        return np.zeros(1), CallTimes(device_ms, transfer_ms, {"n": len(calls)})
    return call, calls


def test_measure_takes_medians_after_a_warm_up():
    call, calls = _timed_call(0.06, 0.01)
    _, t = measure(call, runs=3, prepare_ms=2.0, build_ms=5.0)
    assert len(calls) == 4 and t.runs == 3 and t.counts == {"n": 1}
    assert 9.0 <= t.time_ms < 40.0 and t.device_ms == 1.0 and t.transfer_ms == 0.5
    assert t.host_ms == pytest.approx(t.time_ms - 1.5, abs=1.0)
    assert t.compile_ms >= 5.0 + 30.0          # the build plus the warm-up's extra ~50 ms
    assert t.prepare_ms == 2.0 and set(t.to_json()) >= set(COLUMNS)
    call, calls = _timed_call(0.0, 0.0, device_ms=5.0)
    _, t = measure(call, runs=0)
    assert len(calls) == 1 and t.runs == 0 and t.host_ms == 0.0     # device time above the wall: clamped
    with pytest.raises(InputError, match="runs = -1"):
        measure(call, runs=-1)


def test_measure_times_short_calls_until_they_add_up_to_min_ms():
    call, calls = _timed_call(0.0, 0.01)
    _, t = measure(call, runs=3, min_ms=100.0)
    assert 4 <= t.runs <= 10 and len(calls) == t.runs + 1       # >= 10 ms calls until >= 100 ms
    call, calls = _timed_call(0.0, 0.0)
    _, t = measure(call, runs=3, min_ms=1e9)
    assert t.runs == MAX_RUNS                                     # never more than MAX_RUNS
    _, t = measure(call, runs=0, min_ms=1e9)
    assert t.runs == 0                                            # one call, no warm-up: min_ms unused
