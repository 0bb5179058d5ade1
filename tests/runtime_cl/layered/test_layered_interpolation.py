"""What a lens ray sees where it hits a peeled surfel (hidden behind a nearer layer's pixel): the
surface's colour at the hit point, not its cell's. Checked against a numpy brute force that
replays each pixel's lens rays (the kernel's sample set and per-pixel offsets), finds their hits
by testing every cell (layered_reference.brute_force_hits) and evaluates the hidden surface's
colour, a linear ramp, exactly at each hit point."""
import numpy as np
import pytest
from layered_reference import brute_force_hits

import runtime_cl
from runtime_cl.camera.thin_lens import ThinLens
from runtime_cl.errors import InputError
from runtime_cl.layered.lens_samples import disc_samples
from runtime_cl.layered.tracer import LayerTracer, layer_stack

CAMERA = ThinLens(focal_length_mm=50.0, f_number=1.0, focus_distance_m=1.0)
H, W, RAYS = 24, 48, 16
SLOPE = np.array([0.05, 0.02])   # the wall's colour per pixel in x and y: a ray's sub-pixel offset shows


def _hash(x):
    """The kernel's hash_u32 (uint32 arithmetic)."""
    x = np.uint64(x) & np.uint64(0xFFFFFFFF)
    for shift, mul in ((16, 0x7feb352d), (15, 0x846ca68b)):
        x ^= x >> np.uint64(shift)
        x = (x * np.uint64(mul)) & np.uint64(0xFFFFFFFF)
    return x ^ (x >> np.uint64(16))


def _scene():
    """A grey bar at 0.4 m (CoC -8.8 px) across the middle in front of a wall at 10 m (+5.3 px)
    whose colour ramps linearly. Layer 1 is the whole wall (where layer 0 shows the wall too, rays
    hit layer 0: ties go to the nearer layer), so bilinear reads behind the bar have their four
    cells on the same surface and give the ramp exactly."""
    ys, xs = np.mgrid[0:H, 0:W]
    ramp = 0.2 + SLOPE[0] * (xs + 0.5) + SLOPE[1] * (ys + 0.5)     # the wall's colour at cell centres
    wall = np.repeat(ramp[..., None], 3, axis=2).astype(np.float32)
    bar = (xs >= 20) & (xs < 28)
    front_rgb = np.where(bar[..., None], np.float32(0.1), wall)
    front_z = np.where(bar, 0.4, 10.0)
    layers = [(front_rgb, np.ones((H, W), np.float32), front_z),
              (wall, np.ones((H, W), np.float32), np.full((H, W), 10.0))]
    return layer_stack(layers), front_rgb, bar


def _brute_force(stack, front_rgb, bar, scale, thickness):
    """Each pixel's mean colour over its rays that hit, replayed in float64."""
    samples = disc_samples(2 * RAYS).astype(np.float64)
    out = np.zeros((H, W))
    for y in range(H):
        for x in range(W):
            o = int(_hash(y * W + x) % np.uint64(2 * RAYS))   # seed 0: hash_u32(0) = 0
            b = samples[(o + np.arange(RAYS)) % (2 * RAYS)] * scale
            a = np.array([x + 0.5, y + 0.5]) - b / CAMERA.focus_distance_m
            hits = brute_force_hits(stack.inv_depth, np.concatenate([a, b], axis=1), thickness)
            colours = []
            for (w, k, cell), aj, bj in zip(hits, a, b):
                if k < 0:
                    continue
                cy, cx = divmod(int(cell), W)
                if k == 0:
                    colours.append(front_rgb[cy, cx, 0])
                else:                                   # hidden wall: its colour at the hit point
                    q = aj + bj * w
                    colours.append(0.2 + SLOPE @ q)
            out[y, x] = np.mean(colours)
    return out


@pytest.mark.parametrize("interpolate", [True, False])
def test_rays_see_a_peeled_surface_at_their_hit_points(interpolate):
    stack, front_rgb, bar = _scene()
    scale = float(CAMERA.coc_scale_px(W))
    tracer = LayerTracer((H, W), 2, RAYS, interpolate_hidden=interpolate)
    image, _ = tracer.render(stack, scale, CAMERA.focus_distance_m, 1.0, 0)
    expected = _brute_force(stack, front_rgb, bar, scale, 1.0 / scale)
    rows = slice(9, 15)   # the middle rows: no ray leaves the image (reach < 9 px)
    near_bar = slice(14, 34)
    err = np.abs(image[rows, near_bar, 0] - expected[rows, near_bar])
    if interpolate:
        # float32 against float64 (colours ~1, float32 hit points and bilinear weights): 1e-5
        assert err.max() < 1e-5
    else:
        # read by cell, a ray gets its cell centre's colour, up to 0.035 off (half a cell of ramp)
        assert err.max() > 1e-3


def test_interpolate_hidden_must_be_a_bool():
    rgb, depth = np.zeros((4, 4, 3), np.float32), np.ones((4, 4))
    with pytest.raises(InputError, match="interpolate_hidden = 'yes': give true or false"):
        runtime_cl.render(rgb, depth, CAMERA, method="layered", rays=4, interpolate_hidden="yes")
