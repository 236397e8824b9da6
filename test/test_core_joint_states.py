"""com_core.robot.joint_states: joint states merged per joint from several publishers,
each joint with its own latest stamp, window means and rest from its own samples."""

from __future__ import annotations

import threading
import time

from com_core.robot.joint_states import TIME_RESET_NS, JointStates

MS = 1_000_000
ARM = ("j1", "j2")
FINGERS = ("f1", "f2")


def two_publishers(arm_hz: float = 1000.0, fingers_hz: float = 30.0) -> JointStates:
    """One second of an arm publisher at ``arm_hz`` (positions 1.0, 2.0, still) and a
    gripper's at ``fingers_hz`` (0.04 m, closing at 0.01 m/s), interleaved by stamp."""
    states = JointStates()
    messages = [(round(k * 1e9 / arm_hz), ARM, [1.0, 2.0], [0.0, 0.0]) for k in range(int(arm_hz))]
    messages += [
        (round(k * 1e9 / fingers_hz), FINGERS, [0.04, 0.04], [-0.01, -0.01])
        for k in range(int(fingers_hz))
    ]
    for message in sorted(messages, key=lambda m: m[0]):
        assert states.add(*message)
    return states


def test_a_message_of_some_joints_merges_into_the_state_each_joint_with_its_own_stamp():
    states = two_publishers()
    assert states.latest == {"j1": (1.0, 0.0), "j2": (2.0, 0.0), "f1": (0.04, -0.01),
                             "f2": (0.04, -0.01)}  # fmt: skip
    stamps = states.stamps()
    assert stamps["j1"] == 999 * MS and stamps["f1"] == round(29 * 1e9 / 30)
    states.add(1000 * MS, ("f1",), [0.03], [0.0])
    assert states.latest["f1"] == (0.03, 0.0) and states.latest["f2"] == (0.04, -0.01)
    assert states.latest["j1"] == (1.0, 0.0)  # the fingers' message leaves the arm alone


def test_one_publisher_of_every_joint_is_the_latest_message():
    states = JointStates()
    for k in range(5):
        states.add(k * 10 * MS, ARM + FINGERS, [k, k + 1.0, 0.04, 0.04], [0.1, 0.2, 0.0, 0.0])
    assert states.latest == {"j1": (4.0, 0.1), "j2": (5.0, 0.2), "f1": (0.04, 0.0),
                             "f2": (0.04, 0.0)}  # fmt: skip


def test_a_windows_mean_is_each_joints_over_its_own_samples():
    """The window's joint states, not the latest: after the window's end the next move
    may have begun (a cached tare's joints give the hand's model its gravity). Each
    publisher's samples count for its joints only, whatever its rate."""
    states = JointStates()
    for stamp, q in ((0, 1.0), (10, 1.0), (20, 1.2), (30, 1.5)):  # 30: the next move
        states.add(stamp, ("j",), [q], [0.0])
    states.add(5, ("f",), [0.02])
    states.add(35, ("f",), [0.04])  # the gripper: two samples, one inside
    assert states.mean_positions(0, 30) == {"j": (1.0 + 1.0 + 1.2) / 3, "f": 0.02}
    assert states.mean_positions(40, 50) == {"j": 1.5, "f": 0.04}  # none inside: the latest
    assert JointStates().mean_positions(0, 10) == {}


def test_a_windows_mean_from_a_1khz_arm_and_a_30hz_gripper():
    means = two_publishers().mean_positions(200 * MS, 700 * MS)
    assert means == {"j1": 1.0, "j2": 2.0, "f1": 0.04, "f2": 0.04}


def test_rest_is_each_joints_own_since_its_last_motion():
    states = JointStates()
    for stamp, q, v in ((0, 0.0, 1.0), (10, 0.5, 0.001), (20, 0.5, 0.0), (30, 0.5, 0.0)):
        states.add(stamp, ("j1",), [q], [v])
    for stamp, v in ((5, 1.0), (15, 1.0), (25, 0.0), (35, 0.0)):  # slower to stop
        states.add(stamp, ("j2",), [0.0], [v])
    states.add(33, ("f1",), [0.04], [-0.05])  # the fingers still move: not asked about

    def still(_name: str, _q: float, v: float) -> bool:
        return abs(v) < 5e-3

    assert states.rested_since(("j1",), still) == 10
    assert states.rested_since(("j1", "j2"), still) == 25
    assert states.rested_since(("j1", "f1"), still) is None  # f1 moves
    assert states.rested_since(("j1", "j3"), still) is None  # never heard
    assert states.rested_since((), still) is None


def test_messages_without_velocities_and_malformed_ones():
    states = JointStates()
    assert states.add(0, ("a", "b"), [0.1, 0.2])  # no velocities: 0
    assert states.latest == {"a": (0.1, 0.0), "b": (0.2, 0.0)}
    assert not states.add(10, ("a", "b"), [0.3])  # not one position per name: nothing kept
    assert states.latest["a"] == (0.1, 0.0)
    states.add(20, ("a", "b"), [float("nan"), 0.4], [1.0, float("inf")])
    assert states.latest == {"a": (0.1, 0.0), "b": (0.4, 0.0)}


def test_samples_out_of_stamp_order_are_put_in_order_and_the_latest_stays():
    states = JointStates()
    states.add(30, ("f",), [0.03])  # a publisher that stamped later, arriving first
    states.add(20, ("f",), [0.02])
    states.add(30, ("f",), [0.035])  # the same stamp again: it replaces
    assert states.latest["f"] == (0.035, 0.0)
    assert [s[0] for s in states.samples("f")] == [20, 30]
    assert states.samples("nothing") == []


def test_each_joint_keeps_its_last_seconds_and_a_restarted_clock_starts_it_again():
    states = JointStates(keep=0.1)
    for k in range(300):
        states.add(k * MS, ("j",), [float(k)])
    samples = states.samples("j")
    assert samples[0][0] == 199 * MS and samples[-1][0] == 299 * MS
    states.add(299 * MS - TIME_RESET_NS - 1, ("j",), [7.0])  # far back: a new clock...
    assert states.samples("j") == [(299 * MS - TIME_RESET_NS - 1, 7.0, 0.0)]
    states = JointStates()
    states.add(TIME_RESET_NS, ("j",), [1.0])
    states.add(TIME_RESET_NS // 2, ("j",), [2.0])  # ...but not a late sample
    assert len(states.samples("j")) == 2 and states.latest["j"] == (1.0, 0.0)


def test_a_reader_in_another_thread_sees_whole_states():
    """The sequencer's run reads the state while its I/O node's thread merges."""
    states, stop = JointStates(keep=0.01), threading.Event()

    def publish() -> None:
        k = 0
        while not stop.is_set():
            k += 1
            states.add(k * MS, ARM, [1.0, 2.0], [0.0, 0.0])
            states.add(k * MS, (f"extra{k % 50}",), [0.0])  # joints keep appearing

    thread = threading.Thread(target=publish)
    thread.start()
    try:
        deadline = time.monotonic() + 0.3
        while time.monotonic() < deadline:
            assert all(name for name in states.latest)
            states.mean_positions(0, 10**12)
            states.rested_since(ARM, lambda *_: True)
    finally:
        stop.set()
        thread.join()
