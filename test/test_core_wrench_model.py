"""com_core.sensing.wrench_model: f = m g_s, tau = p x f, and the sensor model (noise, bias,
quantisation, saturation, seed)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from com_core.sensing.wrench_model import (
    SensorModel,
    gravity_in_sensor,
    gravity_wrench,
    rotation_about,
    skew,
)


def test_wrench_model_geometry():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=3), rng.normal(size=3)
    assert_allclose(skew(a) @ b, np.cross(a, b))
    R = rotation_about(a, 0.7)
    assert_allclose(R @ R.T, np.eye(3), atol=1e-15)
    assert_allclose(R @ a, a)
    w = gravity_wrench(0.3, b, gravity_in_sensor(R))
    assert_allclose(np.linalg.norm(w[:3]), 0.3 * 9.80665)
    assert abs(w[:3] @ w[3:]) < 1e-12  # the torque of a force is perpendicular to it
    with pytest.raises(ValueError, match=r"shape \(3,\), got shape \(2,\)"):
        gravity_wrench(1.0, [1.0, 2.0], [0, 0, -9.8])


def test_sensor_model_statistics_quantisation_saturation_and_seed():
    sensor = SensorModel.from_scalars(
        0.1,
        0.005,
        bias_f=0.3,
        bias_tau=-0.02,
        resolution_f=0.01,
        resolution_tau=0.0005,
        limit_f=20.0,
        limit_tau=1.0,
    )
    true = np.array([1.0, -2.0, 3.0, 0.1, -0.2, 0.05])
    n = 20000
    x = sensor.measure(np.tile(true, (n, 1)), np.random.default_rng(1))
    sd = np.sqrt(np.diag(sensor.sample_covariance()))
    assert_allclose(x.mean(axis=0), true + sensor.bias, atol=5 * sd.max() / math.sqrt(n))
    assert_allclose(x.std(axis=0), sd, rtol=5 / math.sqrt(2 * n))
    assert_allclose(x[:, :3] / 0.01, np.round(x[:, :3] / 0.01), atol=1e-9)
    assert_allclose(x, sensor.measure(np.tile(true, (n, 1)), np.random.default_rng(1)))
    big = sensor.measure([25.0, 0, 0, 0, 0, 0], np.random.default_rng(2))
    assert big[0] == 20.0 and sensor.saturated(big)[0]
    with pytest.raises(ValueError):
        SensorModel.from_scalars(-1.0, 0.0)
