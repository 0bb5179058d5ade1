"""``runtime_cl.masks``: an image's non-zero pixels and their box, against plain numpy."""
import numpy as np
import pytest

from runtime_cl.masks import box_shape, grow_box, inner_box, nonzero_box, nonzero_pixels, on_box, union_box


@pytest.mark.parametrize("channels", [None, 1, 4])
@pytest.mark.parametrize("grow", [0, 3, 50])
def test_box_of_the_nonzero_pixels(channels, grow):
    rng = np.random.default_rng(grow + (channels or 0))
    for _ in range(20):
        shape = (int(rng.integers(1, 40)), int(rng.integers(1, 40))) + (() if channels is None else (channels,))
        a = np.zeros(shape, np.float32)
        for _ in range(int(rng.integers(0, 4))):
            a[(rng.integers(0, shape[0]), rng.integers(0, shape[1])) + (() if channels is None else
                                                                          (rng.integers(0, channels),))] = \
                rng.choice([-2.5, 1e-30, 7.0])   # negative and tiny values count
        box = nonzero_box(a, grow)
        hits = np.argwhere(a.reshape(shape[0], shape[1], -1).any(axis=2))
        if not len(hits):
            assert box is None
            continue
        (y0, x0), (y1, x1) = hits.min(axis=0), hits.max(axis=0) + 1
        want = (slice(max(y0 - grow, 0), min(y1 + grow, shape[0])), slice(max(x0 - grow, 0), min(x1 + grow, shape[1])))
        assert box == want


@pytest.mark.parametrize("channels", [1, 3, 4])
def test_nonzero_pixels_is_any_channel(channels):
    rng = np.random.default_rng(channels)
    a = np.where(rng.random((17, 23, channels)) < 0.7, 0.0, rng.choice([-1.0, 1e-38, 3.0], (17, 23, channels)))
    a = a.astype(np.float32)
    want = np.any(a != 0, axis=2)
    np.testing.assert_array_equal(nonzero_pixels(a), want)
    seed = rng.random((17, 23)) < 0.1
    out = seed.copy()
    assert nonzero_pixels(a, out) is out
    np.testing.assert_array_equal(out, want | seed)


def test_boxes_unite_and_place_an_image():
    a, b = (slice(2, 5), slice(3, 9)), (slice(4, 12), slice(0, 4))
    assert union_box(a, b) == (slice(2, 12), slice(0, 9)) and union_box(a, None) == a
    image = np.arange(18, dtype=np.float32).reshape(3, 6)
    frame = np.zeros((12, 9), np.float32)
    frame[a] = image
    outer = union_box(a, b)
    assert np.array_equal(on_box(image, a, outer), frame[outer])
    assert on_box(image, a, a) is image   # the same box: no copy


def test_boxes_grow_within_the_frame_and_move_into_another():
    box = (slice(2, 5), slice(3, 9))
    assert grow_box(box, 4, (7, 10)) == (slice(0, 7), slice(0, 10)) and box_shape(box) == (3, 6)
    assert grow_box(box, 1, (20, 20)) == (slice(1, 6), slice(2, 10))
    assert inner_box(box, (slice(1, 8), slice(2, 12))) == (slice(1, 4), slice(1, 7))
