"""The regression check (lab.report.regress.compare) and the baseline tolerances (lab.report.baseline)."""
import pytest

from lab.report.baseline import tolerances
from lab.report.regress import compare


def report(ssim, times, seed=7, tol=None):
    r = {"scene": {"name": "tiny"}, "timing_reference": "splat", "settings": {"render": {"seed": seed}},
         "methods": {m: {"ssim": ssim[m], "time_ms": times[m]} for m in ssim}}
    if tol:
        r["tolerances"] = tol
    return r


BASE = report({"spreadlets": 0.80, "splat": 0.81}, {"spreadlets": 10.0, "splat": 40.0})


def test_an_unchanged_report_and_a_loaded_machine_pass():
    assert compare(BASE, BASE) == []
    # everything 3x slower (a loaded machine): the ratio to Splat is unchanged
    assert compare(BASE, report({"spreadlets": 0.80, "splat": 0.81}, {"spreadlets": 30.0, "splat": 120.0})) == []


def test_a_drop_and_a_slowdown_name_the_scene_method_and_figure():
    new = report({"spreadlets": 0.78, "splat": 0.81}, {"spreadlets": 20.0, "splat": 40.0})
    out = compare(BASE, new)
    assert out == ["tiny spreadlets: SSIM 0.8000 -> 0.7800 (dropped more than 0.01)",
                   "tiny spreadlets: time 0.25 -> 0.5 x splat (slower by more than 1.5x)"]
    missing = report({"splat": 0.81}, {"splat": 40.0})
    assert compare(BASE, missing) == ["tiny spreadlets: present in the baseline, missing now"]


def test_the_baselines_own_tolerances_apply():
    loose = dict(BASE, tolerances={"ssim_drop": 0.03, "slowdown": 2.5})
    new = report({"spreadlets": 0.78, "splat": 0.81}, {"spreadlets": 20.0, "splat": 40.0})
    assert compare(loose, new) == []
    assert compare(loose, new, ssim_drop=0.01) == ["tiny spreadlets: SSIM 0.8000 -> 0.7800 (dropped more than 0.01)"]


def test_tolerances_come_from_the_seed_and_run_spreads():
    runs = [report({"spreadlets": s, "splat": s + 0.01}, {"spreadlets": t, "splat": 40.0}, seed=7 + k)
            for k, (s, t) in enumerate([(0.80, 10.0), (0.82, 25.0), (0.78, 11.0)])]
    t = tolerances(runs)
    sd = (2 * 0.02 ** 2 / 3) ** 0.5
    assert t["ssim_drop"] == pytest.approx(3 * sd) and t["slowdown"] == pytest.approx(1 + 2 * (25.0 / 10.0 - 1))
    assert t["evidence"]["seeds"] == [7, 8, 9] and "splat" not in t["evidence"]["time_ratio_spread"]
    calm = tolerances([report({"a": 0.9, "splat": 0.9}, {"a": 1.0, "splat": 2.0})] * 2)
    assert calm["ssim_drop"] == 0.005 and calm["slowdown"] == 4.0        # the floors
