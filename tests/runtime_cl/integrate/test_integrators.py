"""The integrator registry, the float32 FFT path, and the integrator as a render option."""
import numpy as np
import pytest

import runtime_cl
from runtime_cl.camera.thin_lens import ThinLens
from runtime_cl.errors import InputError
from runtime_cl.integrate import DEFAULT_INTEGRATOR, Integrator, get_integrator, integrator_names
from runtime_cl.integrate.poisson import laplacian5, poisson_integrate
from runtime_cl.psf.synthetic import disc_database, psf_sum_image
from runtime_cl.spreadlets.renderer import Renderer

CAMERA = ThinLens(focal_length_mm=50.0, f_number=2.0, focus_distance_m=0.5)


def test_registry_lists_every_integrator():
    assert integrator_names() == ["exact", "fft32", "pyramid"] and DEFAULT_INTEGRATOR == "fft32"
    for name in integrator_names():
        cls = get_integrator(name)
        assert issubclass(cls, Integrator) and cls.name == name and cls.summary
    assert runtime_cl.integrators()["pyramid"] == get_integrator("pyramid").summary


@pytest.mark.parametrize("name", ["bogus", "", None, 3, "Exact"])
def test_unknown_integrator_names_the_valid_ones(name):
    with pytest.raises(InputError, match=r"integrator = .*unknown; choose one of \['exact', 'fft32', 'pyramid'\]"):
        get_integrator(name)


def test_exact_is_poisson_integrate_bit_for_bit():
    lap = laplacian5(psf_sum_image(96, seed=2)).astype(np.float32)
    out, times = get_integrator("exact")()(lap)
    np.testing.assert_array_equal(out, poisson_integrate(lap))
    assert times == {"device_ms": 0.0, "transfer_ms": 0.0}


@pytest.mark.parametrize("shape", [(512, 512, 3), (300, 250)])
def test_fft32_is_within_1e_4_of_exact(shape):
    """float32 FFTs: mean <= 1e-5 and max <= 1e-4 of the channel's largest value (measured
    ~1e-6 / 1e-5); the float64 path is not the float32 one."""
    image = psf_sum_image(max(shape[:2]), seed=5)[:shape[0], :shape[1]]
    image = image if len(shape) == 3 else image[..., 0]
    image[-1], image[:, -1] = 0.0, 0.0
    lap = laplacian5(image).astype(np.float32)
    exact = poisson_integrate(lap).astype(np.float64)
    out = get_integrator("fft32")()(lap)[0]
    assert out.dtype == np.float32 and out.shape == lap.shape
    e = np.abs(out - exact) / np.abs(exact).max(axis=(0, 1))
    assert e.mean() <= 1e-5 and e.max() <= 1e-4 and e.max() > 0


def test_precision_is_checked():
    with pytest.raises(ValueError, match="precision = 'float16'"):
        poisson_integrate(np.zeros((8, 8)), precision="float16")


@pytest.fixture(scope="module")
def scene():
    rng = np.random.default_rng(4)
    h, w = 40, 48
    depth = np.where(np.arange(w)[None, :] < 24, 0.5, 0.3) * np.ones((h, 1))   # in focus | in front
    # smooth colours: on white noise behind a ~1 px blur the pyramid is up to 5 % off (its error
    # grows with the detail at the pixel scale); in-focus pixels take the dense fast track, as
    # in a real database
    y, x = np.mgrid[0:h, 0:w]
    rgb = np.stack([0.5 + 0.4 * np.sin(x / 7.0 + p) * np.cos(y / 5.0 - p) for p in rng.random(3) * 6], -1)
    rgb = rgb.astype(np.float32)
    db = disc_database(float(np.ceil(np.abs(CAMERA.coc_radius_px(depth, w)).max())) + 1, samples=10,
                       fast_track_below=0.5)
    return rgb, depth, db


def test_default_render_is_the_fft32_integrator_bit_for_bit(scene):
    rgb, depth, db = scene
    default, _ = runtime_cl.render(rgb, depth, CAMERA, db)
    fft32, _ = runtime_cl.render(rgb, depth, CAMERA, db, integrator="fft32")
    np.testing.assert_array_equal(default, fft32)


@pytest.mark.parametrize("name, tol", [("fft32", 1e-4), ("pyramid", 0.03)])
def test_render_with_another_integrator(scene, name, tol):
    rgb, depth, db = scene
    exact, _ = runtime_cl.render(rgb, depth, CAMERA, db, integrator="exact")
    got, timing = runtime_cl.render(rgb, depth, CAMERA, db, integrator=name)
    assert np.abs(got - exact).max() <= tol * np.abs(exact).max()
    assert not np.array_equal(got, exact)
    if name == "pyramid":   # its kernels are device time, its copies transfers
        assert timing.device_ms > 0


def test_bad_integrator_options(scene):
    rgb, depth, db = scene
    with pytest.raises(InputError, match=r"integrator = 'fft'.*\['exact', 'fft32', 'pyramid'\]"):
        runtime_cl.render(rgb, depth, CAMERA, db, integrator="fft")
    with pytest.raises(InputError, match=r"'splat' pass integrates no Laplacian.*\['spreadlets'(, 'stochastic_spreadlets')?\]"):
        runtime_cl.render(rgb, depth, CAMERA, db, method="splat", integrator="pyramid")
    with pytest.raises(InputError, match="integrator = 'nope'"):
        Renderer(db, integrator="nope")
