"""The device "over" of one depth layer against the re-weighting written plainly in numpy.

The kernel must give the float32 image numpy gives, bit for bit (each operation rounded alike,
no fused multiply-adds), on the layer's box only, and the layer's coverage before and after the
re-weighting.
"""
import numpy as np
import pytest

from runtime_cl.device.opencl import get_device
from runtime_cl.layers.composite import MIN_KNOWN
from runtime_cl.layers.over import OverKernel


def numpy_over(out, layer, box, hidden, own):
    """The module docstring's formulas of runtime_cl/layers/composite.py, in float32 numpy
    (``hidden``, ``own``: the box's blurs or None)."""
    c = out.shape[2]
    colour, alpha = layer[..., :c], layer[..., c]
    known = np.ones(alpha.shape, np.float32) if hidden is None else np.float32(1.0) - hidden
    weight = np.float32(1.0) / np.clip(np.maximum(known, alpha), np.float32(MIN_KNOWN), np.float32(1.0))
    opacity = np.minimum(alpha * weight, np.float32(1.0))
    covered = float(opacity.sum(dtype=np.float64))
    if own is not None:
        bound = np.minimum(own / np.clip(known, np.float32(MIN_KNOWN), np.float32(1.0)), np.float32(1.0))
        opacity = np.maximum(opacity, bound)
    out = out.copy()
    view = out[box]
    view *= (np.float32(1.0) - opacity)[..., None]
    view += colour * weight[..., None]
    return out, covered, float(np.minimum(alpha, np.float32(1.0)).sum(dtype=np.float64))


@pytest.mark.parametrize("channels", [1, 3])
@pytest.mark.parametrize("with_hidden,with_own", [(False, False), (True, False), (True, True), (False, True)])
def test_over_is_numpys_to_the_bit(channels, with_hidden, with_own):
    rng = np.random.default_rng(channels * 4 + 2 * with_hidden + with_own)
    h, w = 37, 150                       # wider than a work-group: a partial group at the row's end
    box = (slice(5, 30), slice(7, 139))
    bh, bw = 25, 132
    out = (rng.random((h, w, channels)) * 3).astype(np.float32)
    layer = rng.random((bh, bw, channels + 1)).astype(np.float32) * np.float32(2.0)
    layer[..., channels] = np.clip(rng.normal(0.6, 0.5, (bh, bw)), 0, 1.2)   # partial, zero and > 1
    layer[:4] = 0.0                      # rows the layer does not draw
    region = (slice(2, 33), slice(3, 145))   # the blurs' region holds the box
    planes = [rng.random((31, 142)).astype(np.float32)] if with_hidden else []
    if with_own:
        planes.append((rng.random((31, 142)) * 1.5 - 0.2).astype(np.float32))
    blurred = np.stack(planes, axis=2) if planes else None
    inner = (slice(3, 28), slice(4, 136))     # the box in the region's coordinates
    want, covered, total = numpy_over(out, layer, box, planes[0][inner] if with_hidden else None,
                                      planes[-1][inner] if with_own else None)
    got = out.copy()
    c, t, ms = OverKernel(get_device(), channels)(got, layer, box, blurred, region, with_hidden, with_own,
                                                  MIN_KNOWN)
    assert np.array_equal(got, want)
    assert c == pytest.approx(covered, rel=1e-5) and t == pytest.approx(total, rel=1e-5) and ms >= 0
