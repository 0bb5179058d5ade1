"""The layered tracer's thick lens: its rays against the numpy float64 twin and the 3-D lines they
are, its exit-pupil boxes against the lab's, and its images against lens optics."""
import numpy as np
import pytest

from lab.cameras.thick import FOCUS_WAVELENGTH_NM, ThickCamera
from lab.optics.exit_pupil import ExitPupil
from runtime_cl.camera.exit_pupil import PupilBoxes
from runtime_cl.camera.lens_trace import TracedLens
from runtime_cl.layered.thick_tracer import ThickLayerTracer
from runtime_cl.layered.tracer import layer_stack
from runtime_cl.stochastic.thick import ray_lines

W, H = 128, 64


def camera(focus_m=1.0, lens="singlet", sensor_mm=24.0):
    return ThickCamera(model="thick", position=(0.0, 0.0, 0.0), look_at=(0.0, 0.0, 1.0), lens=lens,
                       focus_distance_m=focus_m, sensor_width_mm=sensor_mm)


def numpy_lines(cam, pupil, pixel_u, channel):
    """(a, b) of the rays the kernel should trace, in float64: the twin's rays, and the line each
    is in the pupil's pinhole image, from two of its points projected."""
    mm_px = cam.sensor_width_mm / W
    sx = -(pixel_u[:, 0] - W / 2) * mm_px
    sy = (pixel_u[:, 1] - H / 2) * mm_px
    qx, qy = pupil.sample(sx, sy, pixel_u[:, 2], pixel_u[:, 3])
    o, d, ok, cos4 = pupil.trace(sx, sy, qx, qy, channel)
    f_px = cam.focal_px(W)

    def project(p):          # lens mm -> (pixel, w in 1/m)
        z = cam.pupil_z_mm - p[:, 2]
        return np.stack([W / 2 + f_px * p[:, 0] / z, H / 2 - f_px * p[:, 1] / z], axis=1), 1000.0 / z

    q1, w1 = project(o + 500.0 * d)
    q2, w2 = project(o + 5000.0 * d)
    b = (q2 - q1) / (w2 - w1)[:, None]
    a = q1 - b * w1[:, None]
    return np.concatenate([a, b], axis=1), ok & (d[:, 2] < 0), cos4


@pytest.mark.parametrize("lens", ["singlet", "achromat"])
def test_kernel_rays_are_the_lens_rays_as_image_lines(lens):
    """The kernel's (a, b) per ray equal the lines of the float64 twin's rays through the lens,
    found independently by projecting two points of each ray (500 mm and 5 m along it); blocked
    rays agree. Tolerance: float32 tracing (~1e-5 mm at the lens) moves a line by < 1e-3 px. The
    re-centring's float64 lines of the same rays match the projected ones to rounding."""
    cam = camera(lens=lens).runtime_camera()
    tracer = ThickLayerTracer(cam, (H, W), 1, 4)
    rng = np.random.default_rng(1)
    n = 4000
    pixel_u = np.concatenate([rng.uniform(0, [W, H], (n, 2)), rng.random((n, 2))], axis=1)
    channel = rng.integers(0, 3, n)
    got, weight = tracer.ray_lines(pixel_u, channel)
    ref, ok, cos4 = numpy_lines(cam, tracer.pupil, pixel_u, channel)
    assert 0.2 < ok.mean() < 0.95                        # the box holds blocked rays too
    agree = (weight > 0) == ok
    assert agree.mean() > 0.998                          # float32 at the rims may flip a few
    both = ok & (weight > 0)
    np.testing.assert_allclose(got[both], ref[both], atol=2e-3, rtol=1e-4)
    np.testing.assert_allclose(weight[both], cos4[both], rtol=1e-5)
    # the stochastic re-centring's numpy lines (runtime_cl/stochastic/thick.py) are the same lines
    a, b, lines_ok = ray_lines(cam, tracer.pupil, (H, W), pixel_u[:, :2], pixel_u[:, 2:], channel)
    assert np.array_equal(lines_ok, ok)
    np.testing.assert_allclose(np.concatenate([a, b], axis=1)[ok], ref[ok], atol=1e-6, rtol=1e-9)


def test_pupil_boxes_hold_the_labs_boxes():
    """The runtime's boxes (union over the channels) contain the lab's exit-pupil boxes of the
    focus wavelength, and are not much bigger (grid-cell margins)."""
    cam = camera()
    rt = cam.runtime_camera()
    half = 0.5 * np.hypot(24.0, 24.0 * H / W)
    ours = PupilBoxes.build(TracedLens.from_camera(rt), half, n_radii=17, grid=160)
    lab = ExitPupil.build(cam.optics(W), FOCUS_WAVELENGTH_NM, half, n_radii=17, grid=160)
    assert np.all(ours.boxes_mm[:, 0] <= lab.boxes_mm[:, 0] + 0.05)
    assert np.all(ours.boxes_mm[:, 1] >= lab.boxes_mm[:, 1] - 0.05)
    assert np.all(ours.boxes_mm[:, 2] >= lab.boxes_mm[:, 2] - 0.05)
    assert np.all(ours.boxes_mm[:, 1] - ours.boxes_mm[:, 0] < 1.2 * (lab.boxes_mm[:, 1] - lab.boxes_mm[:, 0]))


def test_in_focus_plane_is_sharp_and_a_near_plane_blurs_by_the_paraxial_coc():
    """A step edge on a plane at the focus distance comes out sharp (centre of the frame, where
    aberrations are small), and on a plane at 0.25 m it blurs over about the paraxial CoC diameter
    (spherical aberration widens or narrows it by up to a third at this aperture)."""
    cam = camera(focus_m=1.0).runtime_camera()
    tracer = ThickLayerTracer(cam, (H, W), 1, 64)
    rgb = np.zeros((H, W, 3), np.float32)
    rgb[:, W // 2:] = 1.0
    alpha = np.ones((H, W), np.float32)
    for depth in (1.0, 0.25):
        stack = layer_stack([(rgb, alpha, np.full((H, W), depth))])
        img, info = tracer.render(stack)
        row = img[H // 2, :, 1]
        width = np.count_nonzero((row > 0.02) & (row < 0.98))
        assert info["rays_hit"] > 0
        if depth == 1.0:
            assert width <= 2, row
        else:
            expect = 2.0 * abs(cam.coc_radius_px(depth, W))
            assert 8 < expect and 0.67 * expect <= width <= 1.33 * expect + 1, (width, expect)


def rms_radius(img):
    y, x = np.mgrid[:img.shape[0], :img.shape[1]]
    out = []
    for c in range(3):
        m = img[..., c] / img[..., c].sum()
        cy, cx = (m * y).sum(), (m * x).sum()
        out.append(float(np.sqrt((m * ((y - cy) ** 2 + (x - cx) ** 2)).sum())))
    return out


def test_axial_colour_blurs_red_more_in_front_of_the_focus_and_blue_more_behind():
    """The singlet's N-BK7 focuses blue nearer the lens than red (1/V ~ 1/64 of its power): a white
    point in front of the focus images behind the sensor, blue nearest it, so blue blurs least; a
    point behind the focus the other way round. At 256 px the channels' CoCs differ by ~2 px."""
    w, h = 256, 96
    cam = camera(focus_m=1.0).runtime_camera()
    tracer = ThickLayerTracer(cam, (h, w), 1, 256)
    rgb = np.zeros((h, w, 3), np.float32)
    rgb[h // 2 - 1:h // 2 + 1, w // 2 - 1:w // 2 + 1] = 1.0
    alpha = np.ones((h, w), np.float32)
    near, _ = tracer.render(layer_stack([(rgb, alpha, np.full((h, w), 0.4))]))
    far, _ = tracer.render(layer_stack([(rgb, alpha, np.full((h, w), 4.0))]))
    r_near, r_far = rms_radius(near), rms_radius(far)
    assert r_near[0] > 1.08 * r_near[2], r_near
    assert r_far[2] > 1.08 * r_far[0], r_far
