"""Many random walks of very unequal length on a few SIMD lanes (persistent lanes).

Dr.Jit's LLVM backend runs a symbolic :func:`drjit.while_loop` one SIMD packet (16 lanes with
AVX-512) at a time, and a packet loops until its *last* lane is done. With one walk per lane and a
long-tailed number of steps -- a photon in fog: ~25 collisions on average at 5 m, 1 % over 95 --
most of the work is lanes waiting, masked out, for the longest walk of their packet (a packet of
16 walks runs ~2.9x the mean).

:func:`run_walks` instead gives each of ``lanes`` lanes one walk, and a lane whose walk has ended
stores its result and takes the next walk index from a shared counter (an atomic
:func:`drjit.scatter_inc`), inside the same loop. Both threads' lanes draw from the one pool, so a
thread that other processes slow down simply runs fewer walks (a thread runs its block's packets
one after another: its first packet ends up running most walks, the others their first). Each iteration takes ``unroll`` steps (the loop's own bookkeeping -- blending every
state variable with the loop's mask -- is paid once for them), and lanes look for a new walk
every ``period`` iterations: the restart is a branch every lane of the packet executes when any
one needs it (a few hundred cycles: a scattered store, an atomic, gathers), so checking less often
lets several lanes share it, while an ended walk idles for up to ``period * unroll - 1`` steps.

Which lane runs which walk depends on timing, so a walk must draw its random numbers from a
generator chosen by its index (``start`` does that), never from the lane: the results are then
bitwise reproducible.
"""
from __future__ import annotations

from typing import Callable

import drjit as dr
from drjit.llvm import Bool, UInt32

__all__ = ["run_walks", "UNROLL", "RESTART_PERIOD"]

# Steps per iteration and iterations between looks for ended walks (see the module docstring).
# Measured for the Volume model (walks of ~25 steps): (2, 4) fastest; (2, 2), (2, 3), (3, 3)
# within 5 %; (1, 6), (1, 8) ~10 % slower.
UNROLL = 2
RESTART_PERIOD = 4


def run_walks(n_walks: int, lanes: int, start: Callable, step: Callable, going: Callable,
              store: Callable, unroll: int = UNROLL, period: int = RESTART_PERIOD) -> None:
    """Run walks 0 .. n_walks-1 to their ends on ``lanes`` SIMD lanes; ``store`` records each.

    Parameters
    ----------
    n_walks : int
        Number of walks (>= 1).
    lanes : int
        Lanes to run them on (1 .. n_walks); lane i starts with walk i. Dr.Jit hands a kernel to
        its threads in blocks of 16384 lanes, so use at least that many per thread.
    start : callable
        ``start(walk, valid) -> state``: the state (a tuple of Dr.Jit arrays or traversable
        objects, e.g. a ``PCG32``) of walk ``walk`` (UInt32) before its first step, its random
        generator included. ``valid`` is False for indices >= n_walks (a lane with nothing left
        to do, which never steps): mask gathers with it.
    step : callable
        ``step(walk, *state) -> state``: one step of walk ``walk``. It is also applied to walks
        that have ended (until their lane restarts) and must then leave what ``store`` records
        unchanged.
    going : callable
        ``going(*state) -> Bool``: whether the walk takes another step (checked after each step,
        so a walk takes at least one).
    store : callable
        ``store(walk, *state)``: record an ended walk (scatters into the caller's arrays; the
        writes are masked to the lanes that store).
    unroll : int, default UNROLL
        Steps per loop iteration (>= 1).
    period : int, default RESTART_PERIOD
        Iterations between looks for ended walks (>= 1).
    """
    if not 1 <= lanes <= n_walks:
        raise ValueError(f"lanes = {lanes}: need 1 <= lanes <= n_walks = {n_walks}")
    if unroll < 1 or period < 1:
        raise ValueError(f"unroll = {unroll}, period = {period}: need both >= 1")
    counter = dr.opaque(UInt32, lanes, 1)   # the next walk to hand out
    total = dr.opaque(UInt32, n_walks)

    def restart(walk, *state):
        store(walk, *state)
        walk = dr.scatter_inc(counter, UInt32(0))
        return (walk, *start(walk, walk < total))

    def carry_on(walk, *state):
        return (walk, *state)

    def cond(tick, walk, *state):
        return walk < total

    def body(tick, walk, *state):
        for _ in range(unroll):
            state = step(walk, *state)
        ended = ~going(*state)
        if period > 1:
            ended &= tick % period == 0
        return (tick + 1, *dr.if_stmt((walk, *state), ended, restart, carry_on))

    walk = dr.arange(UInt32, lanes)
    dr.while_loop((dr.zeros(UInt32, lanes), walk, *start(walk, dr.full(Bool, True, lanes))), cond, body)
