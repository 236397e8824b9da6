"""com_core.sensing.noise and the windows under correlated noise: the learnt model against the
noise it was learnt from, window-mean covariance against Monte Carlo, the motion tests'
false alarms, the settling, and a noise-free sensor."""

from __future__ import annotations

import math

import numpy as np
import pytest

from com_core.estimation.fits.errors import MotionError
from com_core.estimation.fits.windows import reduce_window, settled_start
from com_core.sensing.noise import (
    COV_FLOOR,
    MAX_ORDER,
    NoiseModel,
    ar1_noise,
    learn_noise,
    white_noise,
)

SIGMA = np.array([0.1, 0.1, 0.1, 0.005, 0.005, 0.005])
RATE = 1000.0


def ar1(n: int, tau: float, rng: np.random.Generator, sigma=SIGMA) -> np.ndarray:
    """(n, 6) stationary AR(1) of std ``sigma`` per sample, correlation time tau (s)."""
    phi = math.exp(-1.0 / (RATE * tau))
    e = rng.standard_normal((n, 6)) * sigma * math.sqrt(1 - phi**2)
    x = np.empty((n, 6))
    x[0] = rng.standard_normal(6) * sigma
    for t in range(1, n):
        x[t] = phi * x[t - 1] + e[t]
    return x


def second_order(n: int, cutoff: float, rng: np.random.Generator, count: int) -> np.ndarray:
    """(count, n, 6) white noise through a second-order (critically damped) low-pass at
    7 kHz, every 7th sample kept, scaled to SIGMA: a sensor's filter not of first order."""
    a = math.exp(-2 * math.pi * cutoff / 7000.0)
    e = rng.standard_normal((7 * n + 2000, count, 6))
    y1 = np.zeros((count, 6))
    y2 = np.zeros((count, 6))
    out = np.empty_like(e)
    for t in range(len(e)):
        y1 = a * y1 + (1 - a) * e[t]
        y2 = a * y2 + (1 - a) * y1
        out[t] = y2
    kept = out[2000::7][:n].transpose(1, 0, 2)
    return kept / out[2000:].std(axis=(0, 1)) * SIGMA


def test_ar1_model_mean_factor_is_the_closed_form():
    """f(n) of an AR(1) is (1 + phi) / (1 - phi) - 2 phi (1 - phi^n) / (n (1 - phi)^2)."""
    tau = 0.005
    model = ar1_noise(SIGMA, tau, RATE)
    phi = math.exp(-1 / (RATE * tau))
    for n in (1, 2, 10, 900, 5000):
        exact = (1 + phi) / (1 - phi) - 2 * phi * (1 - phi**n) / (n * (1 - phi) ** 2)
        np.testing.assert_allclose(model.mean_factor(n), exact, rtol=1e-9)
    np.testing.assert_allclose(model.long_run_factor, (1 + phi) / (1 - phi), rtol=1e-12)
    np.testing.assert_allclose(white_noise(np.diag(SIGMA**2)).mean_factor(900), 1.0)


def test_a_quantisation_after_the_low_pass_is_white_noise_in_the_model():
    """AR(1) through the low-pass plus a white error after it (the realistic sensor's
    quantisation, 1/16 N and 1/2000 N m): the model's autocovariance is the sum's to lag
    ``MAX_ORDER``, its long-run factor the ARMA(1, 1)'s closed form, and the white part
    whitens: its prediction errors of a long simulated sum have the innovation's variance
    and no lag-1 correlation (within 3 % and 0.02)."""
    tau = 0.005
    white = np.array([1 / 16] * 3 + [1 / 2000] * 3) / math.sqrt(12)
    model = ar1_noise(SIGMA, tau, RATE, white)
    phi = math.exp(-1 / (RATE * tau))
    gamma = SIGMA[:, None] ** 2 * phi ** np.arange(MAX_ORDER + 1)[None, :]
    gamma[:, 0] += white**2
    np.testing.assert_allclose(model.autocorrelation(MAX_ORDER), (gamma / gamma[:, :1]).T,
                               rtol=1e-9)  # fmt: skip
    long_run = (SIGMA**2 * (1 + phi) / (1 - phi) + white**2) / (SIGMA**2 + white**2)
    np.testing.assert_allclose(model.long_run_factor, long_run, rtol=1e-6)
    rng = np.random.default_rng(3)
    x = ar1(200_000, tau, rng) + white * rng.standard_normal((200_000, 6))
    e = model.prediction_errors(x)
    np.testing.assert_allclose(e.var(axis=0), model.innovation, rtol=0.03)
    lag1 = [np.corrcoef(e[1:, a], e[:-1, a])[0, 1] for a in range(6)]
    assert np.all(np.abs(lag1) < 0.02), lag1
    assert ar1_noise(SIGMA, tau, RATE).orders == (1,) * 6  # no white part: AR(1)


@pytest.mark.parametrize("tau", [0.001, 0.005, 0.02])
def test_learnt_model_gives_the_window_mean_variance(tau):
    """Learnt from a tare-like pass (5 windows of 5 s, 5 of 0.9 s), the variance of a
    0.9 s window's mean is within 15 % of the true AR(1)'s (the learning's own spread
    at 30k samples is ~5-10 % at 20 ms)."""
    rng = np.random.default_rng(7)
    segments = [ar1(5000, tau, rng) for _ in range(5)] + [ar1(900, tau, rng) for _ in range(5)]
    learnt = learn_noise([s[len(s) // 2 :] for s in segments], RATE)
    assert learnt is not None
    truth = ar1_noise(SIGMA, tau, RATE)
    np.testing.assert_allclose(learnt.mean_factor(900), truth.mean_factor(900), rtol=0.15)
    np.testing.assert_allclose(np.sqrt(learnt.variance), SIGMA, rtol=0.1)
    # the correlation time reported, against the filter's (to its discretisation)
    np.testing.assert_allclose(learnt.correlation_time, truth.correlation_time, rtol=0.15)


def test_window_covariance_against_monte_carlo_for_a_second_order_filter():
    """A filter that is not first order: the window covariance the model learnt from a
    minute of samples gives matches the spread of 400 window means, per axis within 25 %
    (3 sigma of the Monte Carlo's 7 % and the learning's ~5 %), over the axes within 10 %."""
    rng = np.random.default_rng(11)
    learnt = learn_noise(list(second_order(5000, 30.0, rng, 12)), RATE)
    assert learnt is not None and max(learnt.orders) >= 2
    means = second_order(900, 30.0, rng, 400).mean(axis=1)
    predicted = np.diag(learnt.mean_cov(900))
    ratio = means.var(axis=0, ddof=1) / predicted
    assert np.all(np.abs(ratio - 1) < 0.25) and abs(ratio.mean() - 1) < 0.1, ratio


@pytest.mark.slow
def test_motion_tests_false_alarm_rate_under_correlated_noise():
    """300 static windows of 20 ms correlated noise (the issue's worst): no window is
    refused as motion (the tests are at 6 sigma), and the settling cuts nothing in >= 98 %."""
    rng = np.random.default_rng(5)
    model = learn_noise([ar1(5000, 0.02, rng) for _ in range(5)], RATE)
    refused = cut = 0
    for _ in range(300):
        x = ar1(900, 0.02, rng) + np.array([1.0, 2.0, 9.0, 0.1, 0.2, 0.0])
        try:
            reduce_window("w", x, noise=model)
        except MotionError:
            refused += 1
        cut += settled_start(x, model) > 0
    assert refused == 0
    assert cut <= 6


def test_real_motion_is_still_caught():
    """A drift of 0.5 N over the window (a slow slide), or a 2 Hz sway of 0.2 N, is
    refused under 5 ms correlated noise (0.2 N would be 4.7 sigma of the halves' means:
    correlated noise hides small motion)."""
    rng = np.random.default_rng(9)
    model = learn_noise([ar1(5000, 0.005, rng) for _ in range(4)], RATE)
    t = np.arange(900) / RATE
    slide = ar1(900, 0.005, rng)
    slide[:, 0] += 0.5 * t / t[-1]
    with pytest.raises(MotionError, match="fx drifts"):
        reduce_window("w", slide, noise=model)
    sway = ar1(900, 0.005, rng)
    sway[:, 1] += 0.2 * np.sin(2 * math.pi * 2.0 * t)
    with pytest.raises(MotionError, match="fy"):
        reduce_window("w", sway, noise=model)


def test_ringing_is_cut_and_the_mean_is_the_settled_one():
    """A 12 Hz ringing of 1 N decaying at 0.15 s at a window's start: the window starts
    after it has decayed to the noise's level, and its mean is within 3 sigma of the true
    wrench (what rings on below the noise averages out over the window)."""
    rng = np.random.default_rng(13)
    model = learn_noise([ar1(5000, 0.005, rng) for _ in range(4)], RATE)
    t = np.arange(1500) / RATE
    x = ar1(1500, 0.005, rng)
    x[:, 2] += 1.0 * np.exp(-t / 0.15) * np.sin(2 * math.pi * 12.0 * t)
    start = settled_start(x, model)
    assert 0.2 * RATE <= start <= 0.6 * RATE
    window = reduce_window("w", x, noise=model)
    assert window.n == 1500 - start
    assert np.all(np.abs(window.mean) <= 3 * np.sqrt(np.diag(window.cov)))


def test_noise_free_windows_get_the_floor():
    """The ideal sensor: constant samples give a window whose covariance is the floor."""
    x = np.tile([1.0, 2.0, 9.0, 0.1, 0.2, 0.0], (900, 1))
    model = learn_noise([x, x], RATE)
    assert model is not None
    window = reduce_window("w", x, noise=model)
    np.testing.assert_allclose(np.sqrt(np.diag(window.cov)), COV_FLOOR)
    assert settled_start(x, model) == 0


def test_model_round_trips_and_names_a_changed_noise():
    rng = np.random.default_rng(2)
    model = learn_noise([ar1(4000, 0.005, rng) for _ in range(3)], RATE)
    again = NoiseModel.from_dict(model.as_dict())
    np.testing.assert_array_equal(again.cov, model.cov)
    assert again.ar == model.ar
    same = learn_noise([ar1(4000, 0.005, rng) for _ in range(3)], RATE)
    assert same.changed_from(model) == ""
    louder = learn_noise([2 * ar1(4000, 0.005, rng) for _ in range(3)], RATE)
    assert "noise changed since the tare" in louder.changed_from(model)
