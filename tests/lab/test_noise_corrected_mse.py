"""The noise-corrected MSE: a method's error against the reference's expectation, estimated from
two references with independent noise, on synthetic images whose truth and noise are known."""
import numpy as np
import pytest

from lab.report.metrics import noise_corrected_mse, tonemap


def _images(rng, sigma, shape=(48, 48, 3)):
    truth = rng.uniform(0.05, 0.5, shape)                  # linear, inside the tonemap's clip range
    method = truth + rng.normal(0.0, 0.02, shape)           # the method's own, fixed error
    a = truth + rng.normal(0.0, sigma, shape)
    b = truth + rng.normal(0.0, sigma, shape)
    return truth, method, a, b


@pytest.mark.parametrize("sigma", [0.005, 0.02, 0.05])
def test_it_recovers_the_error_against_the_truth_whatever_the_reference_noise(sigma):
    """Averaged over noise draws it equals the MSE against E[tonemap(reference)]; the raw MSE
    against one noisy reference overstates it by the reference's variance."""
    rng = np.random.default_rng(7)
    truth, method, _, _ = _images(rng, sigma)
    # E[tonemap(truth + noise)] per pixel, by many draws (the tonemap is curved)
    mu = np.mean([tonemap(truth + rng.normal(0.0, sigma, truth.shape)) for _ in range(200)], axis=0)
    want = np.mean((tonemap(method) - mu) ** 2)
    est, raw = [], []
    for _ in range(30):
        a = truth + rng.normal(0.0, sigma, truth.shape)
        b = truth + rng.normal(0.0, sigma, truth.shape)
        est.append(noise_corrected_mse(method, a, b))
        raw.append(np.mean((tonemap(method) - tonemap(a)) ** 2))
    spread = np.std(est) / np.sqrt(len(est))
    assert abs(np.mean(est) - want) < 4 * spread + 0.01 * want, (np.mean(est), want, spread)
    if sigma >= 0.02:
        assert np.mean(raw) > 1.5 * want              # what the correction takes out


def test_identical_references_leave_the_plain_mse():
    rng = np.random.default_rng(8)
    truth, _, a, _ = _images(rng, 0.03)
    m = truth + 0.01
    assert noise_corrected_mse(m, a, a) == pytest.approx(np.mean((tonemap(m) - tonemap(a)) ** 2))
