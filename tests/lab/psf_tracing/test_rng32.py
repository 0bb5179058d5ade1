"""xoroshiro64** (lab.psf_tracing.rng32): the authors' algorithm bit for bit, uniform floats,
independent successive numbers and lanes, and seeding that never yields the all-zero state."""
import drjit as dr
import numpy as np
from drjit.llvm import UInt32, UInt64
from scipy import stats

from lab.psf_tracing.rng32 import Xoroshiro64, next_reference
from lab.psf_tracing.tracer import lane_rng


def test_matches_the_reference_step_bit_for_bit():
    s0 = [0x12345678, 1, 0xFFFFFFFF, 0x9E3779B9]
    s1 = [0x9ABCDEF0, 0, 0xFFFFFFFF, 7]
    rng = Xoroshiro64(UInt32(s0), UInt32(s1))
    for _ in range(100):
        out = rng.next_uint32().numpy()
        expected = []
        for i in range(4):
            o, s0[i], s1[i] = next_reference(s0[i], s1[i])
            expected.append(o)
        assert out.tolist() == expected


def floats(n_lanes, per_lane, seed):
    rng = Xoroshiro64.from_pcg32(lane_rng(n_lanes, seed))
    return np.stack([rng.next_float32().numpy() for _ in range(per_lane)], axis=1)   # (lane, draw)


def test_floats_are_uniform_and_successive_pairs_independent():
    """Chi-square over 256 bins of all draws and over a 32 x 32 grid of successive pairs (the
    Volume walk draws four numbers per collision from one lane), p > 1e-4 each."""
    u = floats(2 ** 16, 16, 1)
    assert u.min() >= 0.0 and u.max() < 1.0
    assert stats.chisquare(np.histogram(u, 256, (0, 1))[0]).pvalue > 1e-4
    pairs, _, _ = np.histogram2d(u[:, :-1].ravel(), u[:, 1:].ravel(), 32, [[0, 1], [0, 1]])
    assert stats.chisquare(pairs.ravel()).pvalue > 1e-4


def test_lanes_and_seeds_are_independent():
    """Neighbouring lanes and the same lane under another seed are uncorrelated."""
    a, b = floats(2 ** 16, 4, 2), floats(2 ** 16, 4, 3)
    bound = 5.0 / np.sqrt(a.size)
    assert abs(np.corrcoef(a[:-1].ravel(), a[1:].ravel())[0, 1]) < bound
    assert abs(np.corrcoef(a.ravel(), b.ravel())[0, 1]) < bound


def test_seeding_never_gives_the_all_zero_state():
    keys = UInt64(np.arange(2 ** 16, dtype=np.uint64))
    rng = Xoroshiro64.from_key(keys)
    assert not np.any((rng.s0.numpy() == 0) & (rng.s1.numpy() == 0))
    assert len(np.unique(rng.s0.numpy().astype(np.uint64) << np.uint64(32) | rng.s1.numpy())) == 2 ** 16
