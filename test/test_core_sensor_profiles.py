"""The parts of a real sensor in ``com_core``: correlated noise, calibration, the profiles.

The noise of a sensor that low-pass filters at its internal rate and publishes every k-th
sample is an AR(1) at the publish rate, coefficient phi = exp(-1 / (rate correlation_time)):
its autocorrelation at lag k is phi^k, its std per sample sigma, and filtering at 7 kHz then
keeping every 7th sample gives the same sequence in distribution. Without correlation and
calibration the readings are the same numbers, draw for draw, as before either existed. The
calibration matrix's elements spread as its definition says, and the profiles hold the
figures docs/design.md states (The simulated sensor).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from com_core.sensing.sensor_profiles import DEFAULT_PROFILE, PROFILES, SensorProfile
from com_core.sensing.wrench_model import SensorModel, calibration_matrix

CORRELATION_TIME = 0.005  # s: the realistic profile's
RATE = 1000.0  # Hz: the publish rate
PHI = math.exp(-1.0 / (RATE * CORRELATION_TIME))
INTERNAL_RATE = 7000.0  # Hz: the sensor's own sampling
LAGS = np.arange(1, 21)


def long_run_factor(phi: float) -> float:
    """(1 + phi^2) / (1 - phi^2): the variance of an AR(1)'s sample autocorrelation (at any
    lag, Bartlett's bound) and of its sample variance (over 2 sigma^4), times the sample
    size."""
    return (1.0 + phi * phi) / (1.0 - phi * phi)


def autocorrelation(x: np.ndarray, lags: np.ndarray) -> np.ndarray:
    """Sample autocorrelation (len(lags), axes) of zero-mean series x (n, axes), pooled
    over the rows of a 3-D x (chains, n, axes) if given."""
    x = x if x.ndim == 3 else x[None]
    var = np.mean(x * x, axis=(0, 1))
    return np.array([np.mean(x[:, :-k] * x[:, k:], axis=(0, 1)) / var for k in lags])


@pytest.fixture(scope="module")
def correlated_noise() -> tuple[SensorModel, np.ndarray]:
    """The realistic noise's readings of a zero wrench, 200 000 samples of 6 axes."""
    model = SensorModel.from_scalars(0.1, 0.005, correlation_time=CORRELATION_TIME)
    return model, model.measure(np.zeros((200_000, 6)), np.random.default_rng(11))


def test_the_coefficient_is_the_filter_decimated_to_the_publish_rate():
    model = SensorModel.from_scalars(0.1, 0.005, correlation_time=CORRELATION_TIME)
    per_internal_sample = math.exp(-1.0 / (INTERNAL_RATE * CORRELATION_TIME))
    assert model.phi == pytest.approx(PHI, rel=1e-15)
    assert model.phi == pytest.approx(per_internal_sample**7, rel=1e-12)
    assert SensorModel.from_scalars(0.1, 0.005).phi == 0.0


def test_the_noise_autocorrelation_is_phi_to_the_lag(correlated_noise):
    model, x = correlated_noise
    n = len(x)
    tolerance = 4.5 * math.sqrt(long_run_factor(PHI) / n)
    measured = autocorrelation(x / model.sigma, LAGS)
    assert_allclose(measured, np.tile(PHI**LAGS, (6, 1)).T, atol=tolerance)


def test_sigma_is_the_std_per_published_sample(correlated_noise):
    model, x = correlated_noise
    n = len(x)
    relative = 4.5 * math.sqrt(2.0 * long_run_factor(PHI) / n) / 2.0  # of the std
    assert_allclose(x.std(axis=0) / model.sigma, 1.0, atol=relative)
    assert_array_equal(np.diag(model.sample_covariance()), model.sigma**2)


def test_filtering_at_7_khz_then_keeping_every_7th_sample_is_the_same_noise():
    """y += (1 - a)(x - y) on white x at 7 kHz, every 7th y kept: the autocovariance at
    lags 1 and 5 (in units of its stationary variance) is that of the AR(1) at 1 kHz."""
    chains, published, k = 2000, 200, 7
    a = math.exp(-1.0 / (INTERNAL_RATE * CORRELATION_TIME))
    rng = np.random.default_rng(12)
    stationary_std = math.sqrt((1.0 - a) / (1.0 + a))
    y = rng.standard_normal(chains) * stationary_std
    kept = np.empty((chains, published))
    for step in range(published * k):
        y = y + (1.0 - a) * (rng.standard_normal(chains) - y)
        if step % k == k - 1:
            kept[:, step // k] = y
    filtered = kept[..., None] / stationary_std
    model = SensorModel.from_scalars(1.0, 1.0, correlation_time=CORRELATION_TIME)
    ar1 = np.array([model.measure(np.zeros((published, 1)), rng) for _ in range(chains)])
    lags = np.array([1, 5])
    tolerance = 4.5 * math.sqrt(long_run_factor(PHI) / (chains * published))
    decimated = autocorrelation(filtered, lags)[:, 0] * np.mean(filtered**2)
    published_ar1 = autocorrelation(ar1, lags)[:, 0] * np.mean(ar1**2)
    assert_allclose(decimated, PHI**lags, atol=tolerance)
    assert_allclose(published_ar1, PHI**lags, atol=tolerance)
    assert_allclose(decimated, published_ar1, atol=2 * tolerance)


def test_a_block_starts_stationary():
    """The first sample of each block is drawn from the stationary law: its spread over
    many blocks is sigma, as every later sample's."""
    model = SensorModel.from_scalars(1.0, 1.0, correlation_time=CORRELATION_TIME)
    rng = np.random.default_rng(13)
    blocks = np.array([model.measure(np.zeros((3, 6)), rng) for _ in range(5000)])
    n = blocks.shape[0] * 6
    assert_allclose(blocks.std(axis=(0, 2)), 1.0, atol=4.5 / math.sqrt(2 * n))


@pytest.mark.parametrize(
    "scalars",
    [
        {},
        {
            "bias_f": 0.2,
            "bias_tau": -0.01,
            "resolution_f": 1 / 16,
            "resolution_tau": 1 / 2000,
            "limit_f": 5.0,
            "limit_tau": 0.3,
        },
    ],
)
@pytest.mark.parametrize("calibration", [None, np.eye(6)])
def test_white_and_exactly_calibrated_is_the_same_numbers_as_before(scalars, calibration):
    """Without correlation and with an exact calibration a reading is the true wrench plus
    bias plus sigma times the next standard normal, quantised and clipped: the same draws
    and the same numbers as the white model's."""
    wrench = np.random.default_rng(14).normal(0.0, 3.0, (2000, 6))
    model = SensorModel.from_scalars(0.1, 0.005, **scalars, calibration=calibration)
    reading = model.measure(wrench, np.random.default_rng(15))
    normals = np.random.default_rng(15).standard_normal(wrench.shape)
    expected = wrench + model.bias + normals * model.sigma
    q = np.where(model.resolution > 0, model.resolution, 1.0)
    expected = np.where(model.resolution > 0, np.round(expected / q) * q, expected)
    expected = np.clip(expected, -model.limit, model.limit)
    assert_array_equal(reading, expected)


def test_the_reading_is_the_calibration_times_the_wrench_plus_the_bias():
    calibration = calibration_matrix(0.01, 290.0, 10.0, np.random.default_rng(16))
    model = SensorModel.from_scalars(bias_f=0.3, bias_tau=-0.02, calibration=calibration)
    wrench = np.random.default_rng(17).normal(0.0, 5.0, (50, 6))
    reading = model.measure(wrench, np.random.default_rng(18))
    assert_allclose(reading, wrench @ calibration.T + model.bias, rtol=0, atol=1e-12)


def test_calibration_errors_spread_as_the_stated_accuracy():
    """C = I + S E S^-1, E's elements N(0, (accuracy / 2)^2): in full-scale units every
    element of C - I spreads by accuracy / 2, and a torque's share in a force by the ratio
    of the full scales."""
    accuracy, full_f, full_tau = 0.01, 290.0, 10.0
    rng = np.random.default_rng(19)
    draws = np.array(
        [calibration_matrix(accuracy, full_f, full_tau, rng) for _ in range(4000)]
    ) - np.eye(6)
    scale = np.array([full_f] * 3 + [full_tau] * 3)
    in_full_scale = draws * scale[None, None, :] / scale[None, :, None]
    n = len(draws)
    assert_allclose(in_full_scale.std(axis=0), accuracy / 2, rtol=4.5 / math.sqrt(2 * n))
    assert_allclose(in_full_scale.mean(axis=0), 0.0, atol=4.5 * accuracy / 2 / math.sqrt(n))
    assert draws[:, 0, 3].std() == pytest.approx(accuracy / 2 * full_f / full_tau, rel=0.1)
    assert calibration_matrix(0.0, full_f, full_tau, rng) == pytest.approx(np.eye(6))


def test_the_profiles_hold_their_figures():
    ideal, white, realistic = PROFILES["ideal"], PROFILES["white"], PROFILES["realistic"]
    assert DEFAULT_PROFILE == "realistic"
    assert ideal == SensorProfile() and ideal.modes == ()
    assert (ideal.sigma_f, ideal.sigma_tau, ideal.calibration_accuracy) == (0.0, 0.0, 0.0)
    assert white == SensorProfile(sigma_f=0.1, sigma_tau=0.005)
    assert (realistic.sigma_f, realistic.sigma_tau) == (0.1, 0.005)
    assert realistic.correlation_time == CORRELATION_TIME
    assert (realistic.limit_f, realistic.limit_tau) == (290.0, 10.0)
    assert realistic.calibration_accuracy == 0.01
    assert (realistic.warmup_f, realistic.warmup_tau, realistic.warmup_time) == (0.3, 0.015, 600)
    assert (realistic.random_walk_f, realistic.random_walk_tau) == (2e-4, 1e-5)
    assert realistic.modes == ((12.0, 0.03), (27.0, 0.02))
    assert realistic.resolution_f < realistic.sigma_f
    assert realistic.resolution_tau < realistic.sigma_tau


def test_the_ur_e_series_figures_follow_from_the_ur5e_datasheet():
    """Range 50 N, 10 N m; precision 3.5 N, 0.2 N m as 2 sigma of a reading; the accuracy
    the precision leaves (root-sum-square of 4.0 N, 0.3 N m) between its force and torque
    shares of full scale; the rest the realistic profile's."""
    ur, realistic = PROFILES["ur_e_series"], PROFILES["realistic"]
    assert (ur.limit_f, ur.limit_tau) == (50.0, 10.0)
    assert (ur.sigma_f, ur.sigma_tau) == (3.5 / 2, 0.2 / 2)
    shares = (math.sqrt(4.0**2 - 3.5**2) / 50.0, math.sqrt(0.3**2 - 0.2**2) / 10.0)
    assert min(shares) < ur.calibration_accuracy < max(shares)
    assert ur.problems() == []
    assert (ur.resolution_f, ur.resolution_tau) == (0.0, 0.0)
    same = ("correlation_time", "warmup_f", "warmup_tau", "warmup_time", "random_walk_f",
            "random_walk_tau", "vibration_hz", "vibration_damping", "vibration_gain")  # fmt: skip
    assert all(getattr(ur, name) == getattr(realistic, name) for name in same)


def test_the_bota_sensone_figures_follow_from_botas_published_ones():
    """Sensitivity 0.05 N, 0.002 N m as one sigma of a reading; accuracy 2 % of the
    lateral force's 500 N and the lateral torque's 15 N m; no quantisation nor hysteresis
    stated; the rest the realistic profile's."""
    bota, realistic = PROFILES["bota_sensone"], PROFILES["realistic"]
    assert (bota.sigma_f, bota.sigma_tau) == (0.05, 0.002)
    assert (bota.limit_f, bota.limit_tau, bota.calibration_accuracy) == (500.0, 15.0, 0.02)
    assert (bota.resolution_f, bota.resolution_tau, bota.hysteresis) == (0.0, 0.0, ())
    assert bota.problems() == [] and bota.stated_hysteresis() is None
    same = ("correlation_time", "warmup_f", "warmup_tau", "warmup_time", "random_walk_f",
            "random_walk_tau", "vibration_hz", "vibration_damping", "vibration_gain")  # fmt: skip
    assert all(getattr(bota, name) == getattr(realistic, name) for name in same)


def test_the_realistic_counts_below_the_noise_leave_the_mean_unbiased():
    """A count below the noise is dithered by it: the mean reading of a wrench anywhere
    between two counts is the wrench, and the spread per sample is sigma^2 + q^2 / 12
    (``sample_covariance``)."""
    p = PROFILES["realistic"]
    model = SensorModel.from_scalars(
        p.sigma_f, p.sigma_tau, resolution_f=p.resolution_f, resolution_tau=p.resolution_tau
    )
    rng = np.random.default_rng(20)
    n = 100_000
    spread = np.sqrt(np.diag(model.sample_covariance()))
    for fraction in np.linspace(0.0, 0.875, 8):
        wrench = np.full((n, 6), 2.0) + fraction * model.resolution
        reading = model.measure(wrench, rng)
        assert np.all(np.abs(reading.mean(axis=0) - wrench[0]) < 4.5 * spread / math.sqrt(n))
        assert_allclose(reading.std(axis=0), spread, rtol=4.5 / math.sqrt(2 * n))


def test_overrides_change_one_part_and_refuse_an_unknown_one():
    changed = PROFILES["realistic"].with_overrides(
        sigma_f=0.2, vibration_hz=(), vibration_damping=()
    )
    assert changed.sigma_f == 0.2 and changed.modes == ()
    assert changed.correlation_time == PROFILES["realistic"].correlation_time
    with pytest.raises(ValueError, match="sigma_x"):
        PROFILES["white"].with_overrides(sigma_x=1.0)
    with pytest.raises(ValueError, match="same length"):
        _ = PROFILES["realistic"].with_overrides(vibration_damping=(0.1,)).modes
