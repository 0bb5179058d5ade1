"""Persistent lanes (lab.psf_tracing.walks.run_walks): every walk runs to its end exactly once and
what it records does not depend on the lanes, the steps per iteration or the restart period."""
import drjit as dr
import numpy as np
import pytest
from drjit.llvm import UInt32

from lab.psf_tracing.walks import run_walks

N = 50_000


def walk_lengths(n):
    """Steps of walk i: 1 .. 97, very unequal (as photons are)."""
    i = np.arange(n, dtype=np.uint64)
    return ((i * 2654435761) % 97 + 1).astype(np.uint32)


def run(lanes, unroll, period):
    lengths = UInt32(walk_lengths(N))
    steps_out = dr.zeros(UInt32, N)
    stores = dr.zeros(UInt32, N)
    dr.make_opaque(steps_out, stores)

    def start(walk, valid):
        return dr.gather(UInt32, lengths, walk, valid), dr.zeros(UInt32, dr.width(walk))

    def step(walk, left, taken):                # an ended walk (left == 0) records nothing more
        going = left > 0
        return dr.select(going, left - 1, left), dr.select(going, taken + 1, taken)

    def store(walk, left, taken):
        dr.scatter(steps_out, taken, walk)
        dr.scatter_add(stores, UInt32(1), walk)

    run_walks(N, lanes, start, step, lambda left, taken: left > 0, store, unroll, period)
    return steps_out.numpy(), stores.numpy()


@pytest.mark.parametrize("lanes, unroll, period", [(N, 1, 1), (1000, 1, 1), (1000, 2, 4), (333, 3, 2),
                                                   (17, 1, 8)])
def test_every_walk_ends_once_with_its_own_steps(lanes, unroll, period):
    steps, stores = run(lanes, unroll, period)
    assert np.all(stores == 1) and np.array_equal(steps, walk_lengths(N))


@pytest.mark.parametrize("lanes, unroll, period", [(0, 1, 1), (N + 1, 1, 1), (10, 0, 1), (10, 1, 0)])
def test_bad_arguments_are_refused(lanes, unroll, period):
    with pytest.raises(ValueError, match="need"):
        run_walks(N, lanes, None, None, None, None, unroll, period)
