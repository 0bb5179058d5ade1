"""The Pareto front of accuracy against time on hand-made points, and its sentence."""
import math

from lab.report.pareto import front_sentence, pareto_front


def pt(method, t, s, knob=None, value=None):
    return {"method": method, "time_ms": t, "ssim": s, "knob": knob, "value": value}


def test_front_on_a_hand_made_set():
    points = [pt("a", 1.0, 0.70), pt("b", 2.0, 0.80), pt("c", 2.0, 0.75),   # c: as slow as b, worse
              pt("d", 3.0, 0.79),                                           # slower and worse than b
              pt("e", 5.0, 0.90), pt("f", 0.5, 0.60), pt("g", 8.0, 0.90)]   # g: ties e's score, slower
    assert pareto_front(points) == [5, 0, 1, 4]                              # f, a, b, e: by time


def test_front_skips_missing_and_nan_and_keeps_inf():
    points = [pt("a", 1.0, 0.7), pt("b", None, 0.9), pt("c", 2.0, float("nan")), pt("d", 3.0, math.inf)]
    assert pareto_front(points) == [0, 3]


def test_sentence_names_the_ends_and_the_holders():
    points = [pt("filter", 1.0, 0.70), pt("spreadlets", 2.0, 0.80, "integrator", "exact"),
              pt("spreadlets", 4.0, 0.85, "integrator", "fft32"), pt("splat", 9.0, 0.84)]
    s = front_sentence(points)
    assert s.startswith("The SSIM front runs from filter at 1 ms (SSIM 0.700) to spreadlets (integrator = fft32)")
    assert "+0.150 SSIM for 4x the time" in s and "spreadlets 2, filter 1" in s
    one = front_sentence([pt("a", 1.0, 0.9), pt("b", 2.0, 0.8)])
    assert one.startswith("a is the fastest and the most accurate") and "other 1 point" in one


def test_psnr_sentence_carries_its_unit_and_large_ratios_read_plainly():
    points = [{"method": "a", "time_ms": 1.0, "psnr": 20.0}, {"method": "path tracer", "time_ms": 733.0, "psnr": 24.07}]
    s = front_sentence(points, "psnr", "PSNR", 2, " dB")
    assert "(PSNR 20.00 dB)" in s and "+4.07 dB PSNR for 733x the time" in s
