"""The sim's per-step shortcuts give the numbers of the plain computations, bit for bit.

The node publishes the wrench and the clock as serialized bytes
(``com_core.bags.cdr.WrenchStampedEncoder``, ``encode_clock``): they decode to the message
they stand for, with each float's bits. A sensor mounted as its URDF frame skips the
product with the identity (``SimNode._mounted``); a bias without warm-up or random walk is
a shared zero (``BiasDrift.at``); a sensor without range flags saturation where a reading
is infinite (``WrenchSensor.read``); the model replaced at run time takes effect at the
next reading.
"""

from __future__ import annotations

import itertools
from types import SimpleNamespace

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from com_core.sensing.wrench_model import SensorModel, rotation_about
from wrench_sim.sensor import BiasDrift, WrenchSensor

pytest.importorskip("rclpy")

from geometry_msgs.msg import WrenchStamped
from rclpy.serialization import deserialize_message, serialize_message
from rosgraph_msgs.msg import Clock

from com_core.bags.cdr import WrenchStampedEncoder, encode_clock
from wrench_sim.sim_node import SimNode

# values whose bits a careless encoding or a skipped operation would change
AWKWARD = [0.0, -0.0, 1.5, -2.25, 1e-300, -5e-324, 1e308, 0.1, np.pi]


def bits(values) -> list[int]:
    return np.asarray(values, dtype=np.float64).view(np.int64).tolist()


@pytest.mark.parametrize("frame", ["ft_sensor", "world", "", "a", "sensor_0123456"])
def test_wrench_bytes_decode_to_the_message(frame):
    encoder = WrenchStampedEncoder(frame)
    rng = np.random.default_rng(1)
    for now in (0, 1_000_000, 1_234_567_891, 2_000_000_000_000):
        wrench = rng.choice(AWKWARD, 6) * rng.choice([1.0, -1.0], 6)
        data = encoder.encode(now, wrench.tolist())
        msg = deserialize_message(data, WrenchStamped)
        assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == divmod(now, 1_000_000_000)
        assert msg.header.frame_id == frame
        f, t = msg.wrench.force, msg.wrench.torque
        assert bits([f.x, f.y, f.z, t.x, t.y, t.z]) == bits(wrench)
        assert len(data) == len(serialize_message(msg))


def test_clock_bytes_are_the_serialized_clock():
    for now in (0, 4_000_000, 1_234_567_891, 86_400_000_000_000):
        msg = Clock()
        msg.clock.sec, msg.clock.nanosec = divmod(now, 1_000_000_000)
        assert encode_clock(now) == serialize_message(msg)  # no padding to differ in
        assert deserialize_message(encode_clock(now), Clock) == msg


def test_a_sensor_mounted_as_its_urdf_frame_reads_the_product_with_the_identity():
    identity = rotation_about("z", 0.0) @ rotation_about("y", 0.0) @ rotation_about("x", 0.0)
    shortcut = SimpleNamespace(_mount=identity, _mount_identity=True)
    product = SimpleNamespace(_mount=identity, _mount_identity=False)
    values = [0.0, -0.0, 1.5, -1.5, 1e-300, -5e-324, 1e308]
    for a, b, c in itertools.product(values, repeat=3):
        wrench = np.array([a, b, c, c, a, b])
        assert bits(SimNode._mounted(shortcut, wrench)) == bits(SimNode._mounted(product, wrench))


def test_a_bias_without_warm_up_or_walk_is_zero_as_computed():
    rng = np.random.default_rng(3)
    still = BiasDrift(np.zeros(6), 600.0, np.zeros(6), rng)
    for t in (0.0, 0.001, 5.0, 1e4):
        drift = still.at(t)
        assert bits(drift) == bits(still.final * (1.0 - np.exp(-t / 600.0)) + np.zeros(6))
        assert not drift.flags.writeable
    walking = BiasDrift(np.zeros(6), 600.0, np.full(6, 1e-4), np.random.default_rng(3))
    assert walking.at(1.0).any()  # the walk still moves


def test_saturation_of_a_sensor_without_range_is_where_a_reading_is_infinite():
    model = SensorModel.from_scalars(0.1, 0.005)
    sensor = WrenchSensor(model, np.random.default_rng(0))
    for wrench in ([1.0] * 6, [np.inf, 0, 0, 0, 0, 0], [0, 0, 0, 0, 0, -np.inf], [np.nan] * 6):
        with np.errstate(invalid="ignore"):
            reading = sensor.read(np.array(wrench, dtype=float))
        assert sensor.saturated == bool(model.saturated(reading).any())


def test_a_model_set_at_run_time_takes_effect_at_the_next_reading():
    white = SensorModel.from_scalars(0.1, 0.005, limit_f=1.0, limit_tau=0.1)
    coloured = SensorModel.from_scalars(0.1, 0.005, correlation_time=0.005)
    sensor = WrenchSensor(white, np.random.default_rng(7))
    twin = np.random.default_rng(7).standard_normal((1000, 6))
    wrench = np.array([2.0, 0.5, -3.0, 0.2, 0.0, -0.05])
    assert_array_equal(sensor.read(wrench), white.apply(wrench, twin[0]))
    assert sensor.saturated
    sensor.model = coloured
    first = sensor.read(wrench)  # the filter starts from this sample
    assert_array_equal(first, coloured.apply(wrench, twin[1]))
    assert not sensor.saturated
    phi = coloured.phi
    normal = phi * twin[1] + np.sqrt(1.0 - phi * phi) * twin[2]
    signal = phi * wrench + (1.0 - phi) * wrench
    assert_array_equal(sensor.read(wrench), coloured.apply(signal, normal))
