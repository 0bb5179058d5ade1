"""sparsify(rays=[...]): per-channel ray counts for RGB tracers whose rays pick a channel."""
import numpy as np
import pytest

from lab.errors import UserError
from lab.sparsify import sparsify


def test_per_channel_counts_set_each_channels_noise(rgb_disc, ray_histogram):
    counts = (2 ** 16, 2 ** 20, 2 ** 20)  # red traced with 16x fewer rays: noisier
    noisy = np.concatenate([ray_histogram(rgb_disc[..., c:c + 1], n, seed=c) for c, n in enumerate(counts)],
                           axis=2)
    per_channel = sparsify(noisy, rays=list(counts), anneal_steps=50)
    uniform = sparsify(noisy, rays=2 ** 20, anneal_steps=50)
    assert per_channel.stats["rays"] == 2 ** 16
    # the red channel's noise is recognised: it is smoothed more than with one shared count
    assert per_channel.stats["denoise_sigma"] > uniform.stats["denoise_sigma"]
    assert sparsify(noisy, rays=np.array(counts), anneal_steps=50).stats["rays"] == 2 ** 16


@pytest.mark.parametrize("rays, match", [([2 ** 16, 2 ** 16], "3 channel"), ([2 ** 16, 0, 5], "rays = "),
                                         ([1.5, 2, 3], "rays = ")])
def test_wrong_per_channel_counts_are_errors(rgb_disc, rays, match):
    with pytest.raises(UserError, match=match):
        sparsify(rgb_disc, rays=rays)
