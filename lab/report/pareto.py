"""The Pareto front of accuracy against time, and the sentence that says who holds it."""
from __future__ import annotations

import math

__all__ = ["pareto_front", "front_sentence"]


def pareto_front(points, time_key: str = "time_ms", score_key: str = "ssim") -> list[int]:
    """Indices of the points no other point beats: none is at most as slow and at least as
    accurate with one of the two strictly better. Sorted by time. Points whose time or score is
    missing, a time that is not finite or a NaN score take no part (a PSNR of inf, an identical
    image, is kept: it dominates).

    Parameters
    ----------
    points : sequence of dict
        Each with ``time_key`` (lower is better) and ``score_key`` (higher is better).
    """
    usable = [(float(p[time_key]), float(p[score_key]), i) for i, p in enumerate(points)
              if p.get(time_key) is not None and p.get(score_key) is not None
              and math.isfinite(float(p[time_key])) and not math.isnan(float(p[score_key]))]
    usable.sort(key=lambda t: (t[0], -t[1]))   # fastest first; at equal time the best first
    front, best = [], -math.inf
    for t, s, i in usable:
        if s > best:   # strictly better than everything at most as fast
            front.append(i)
            best = s
    return front


def _name(p) -> str:
    knob = p.get("knob")
    return p["method"] if not knob else f"{p['method']} ({knob} = {p['value']})"


def _ratio(r: float) -> str:
    return f"{r:,.0f}x" if r >= 100 else f"{r:.3g}x"


def front_sentence(points, score_key: str = "ssim", score_label: str = "SSIM", digits: int = 3,
                   unit: str = "") -> str:
    """One sentence that says what the accuracy-vs-time plot of ``points`` shows: the front's two
    ends, and which method holds how much of it (generated from the figures); ``unit`` follows a
    score difference (" dB" for PSNR)."""
    front = pareto_front(points, score_key=score_key)
    if not front:
        return f"No point has both a time and a {score_label}."
    first, last = points[front[0]], points[front[-1]]

    def at(p):
        return f"{p['time_ms']:.3g} ms ({score_label} {p[score_key]:.{digits}f}{unit})"

    if len(front) == 1:
        beaten = len([p for p in points if p.get(score_key) is not None]) - 1
        return (f"{_name(first)} is the fastest and the most accurate at {at(first)}: it beats the other "
                f"{beaten} point(s) on both counts.")
    holders: dict[str, int] = {}
    for i in front:
        holders[points[i]["method"]] = holders.get(points[i]["method"], 0) + 1
    share = ", ".join(f"{m} {n}" for m, n in sorted(holders.items(), key=lambda kv: -kv[1]))
    gain = last[score_key] - first[score_key]
    return (f"The {score_label} front runs from {_name(first)} at {at(first)} to {_name(last)} at {at(last)}: "
            f"{gain:+.{digits}f}{unit} {score_label} for {_ratio(last['time_ms'] / first['time_ms'])} the time; "
            f"of its {len(front)} points, {share}.")
