"""com_core.estimation.runs.exploration: what an Exploration keeps, drops and says about its
input."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from com_core.contract import ERROR, OK, WARN
from com_core.estimation.runs.exploration import Exploration
from com_core.estimation.runs.inbox import MAX_LABEL_GAP, MAX_LABEL_LENGTH
from com_core.estimation.runs.solution import verification_lines
from com_core.paper.synthetic import Load, Stream, exploration_stream
from com_core.planning.planner import Plan

LOAD, HAND = Load(0.1, (0.01, -0.02, 0.1)), Load(0.73, (0.0, 0.0, 0.04))
PLAN = Plan(dwell=0.3, gravity_home=(0, 0, 1))


def fed(stream, exploration: Exploration | None = None, shift_ns: int = 0) -> Exploration:
    """``exploration`` (a new one by default) fed ``stream`` with its stamps shifted."""
    ex = Exploration() if exploration is None else exploration
    ex.add_samples(stream.stamps + shift_ns, stream.wrenches, "ft_sensor")
    for stamp, label in stream.labels:
        ex.add_label(stamp + shift_ns, label)
    return ex


def test_duplicate_stamps_are_named_apart_from_samples_out_of_order():
    ex = Exploration()
    ex.add_samples([10, 20, 20, 30, 15, 30, 40], np.zeros((7, 6)), "ft_sensor")
    assert ex.dropped == {"with a duplicate stamp": 2, "out of time order": 1}
    assert ex.samples()[0].tolist() == [10, 20, 30, 40]


def test_a_run_whose_labels_stopped_is_dropped_when_a_new_one_starts():
    """A sequencer killed mid-run leaves labels and samples behind; a new run's windows
    of the same names must not merge with them (they would look like motion of ~m g)."""
    rng = np.random.default_rng(5)
    aborted = exploration_stream(PLAN, Load(0.5, (0.0, 0.03, 0.12)), HAND, rng)
    cut = next(s for s, lbl in aborted.labels if lbl == "object/tilt_y+")
    keep = aborted.stamps < cut
    ex = Exploration()
    ex.add_samples(aborted.stamps[keep], aborted.wrenches[keep], "ft_sensor")
    for stamp, label in aborted.labels:
        if stamp <= cut:
            ex.add_label(stamp, label)
    clean = exploration_stream(PLAN, LOAD, HAND, rng)
    later = round((MAX_LABEL_GAP + 1.0) * 1e9) + int(aborted.stamps[-1])
    solution = fed(clean, ex, later).solve()
    assert ex.stale_drops == 1
    assert solution.status == OK, solution.reason
    assert abs(solution.estimate.mass - LOAD.mass) < 4 * solution.estimate.sigma_mass
    # the same two runs within the gap are one exploration: its windows merge and fail
    ex = Exploration()
    for stamp, label in aborted.labels:
        if stamp <= cut:
            ex.add_label(stamp, label)
    ex.add_samples(aborted.stamps[keep], aborted.wrenches[keep], "ft_sensor")
    merged = fed(clean, ex, round(5e9) + int(aborted.stamps[-1])).solve()
    assert ex.stale_drops == 0 and merged.status != OK


def test_an_overlong_label_is_refused_and_never_copied_whole():
    stream = exploration_stream(PLAN, LOAD, HAND, np.random.default_rng(6))
    ex = fed(stream)
    ex.add_label(int(stream.stamps[-1]), "object/" + "x" * 10_000)
    solution = ex.solve()
    assert f"dropped 1 labels longer than {MAX_LABEL_LENGTH} characters" in solution.reason
    assert len(solution.reason) < 400 and "xxxx" in solution.reason


def test_an_empty_grasp_is_named_as_such_not_as_a_tare_with_the_object():
    """Object windows that weigh what the tare does: the object was not held."""
    empty = Load(1e-9, (0.0, 0.0, 0.1))
    stream = exploration_stream(PLAN, empty, HAND, np.random.default_rng(7))
    solution = fed(stream).solve()
    assert solution.status == ERROR
    assert "no load beyond the hand" in solution.reason and "not held" in solution.reason
    assert "tare taken with the object" not in solution.reason


def test_late_samples_are_dropped_but_a_restarted_clock_is_not():
    ex = Exploration()
    ex.add_samples([1, 2, 3, 8_000_000_000, 8_000_000_001], np.zeros((5, 6)), "ft_sensor")
    late_and_restarted = [1_000_000_000, 1_000_000_001, 999_000_000, 1_000_000_002]
    assert ex.add_samples(late_and_restarted, np.zeros((4, 6)), "ft_sensor") == 3
    assert ex.dropped == {"out of time order": 1}
    assert ex.time_resets == 1
    assert ex.sample_count == 3  # the old timeline is gone


def kinematic_stream(rng: np.random.Generator, verify: bool = False):
    """A synthetic exploration of the Panda's plan, its joint states, and its robot model:
    the stream's gravity per pose is the forward kinematics' at the choreography's joints;
    ``verify`` adds the choreography's verification window."""

    from conftest import choreography

    from com_core.robot.choreography import VERIFY_POSE

    motion = choreography("panda")
    robot, fingers, arm = motion.robot, motion.others, motion.arm_joints
    home_g = robot.gravity_in_sensor(motion.home_positions())
    plan = Plan(dwell=0.3, gravity_home=tuple(home_g / np.linalg.norm(home_g)))
    joints = dict(motion.pose_joints(plan))
    directions = {}
    if verify:
        joints[VERIFY_POSE] = motion.verify_joints()[0]
        g = robot.gravity_in_sensor(dict(zip(arm, joints[VERIFY_POSE], strict=True)) | fingers)
        directions[VERIFY_POSE] = g / np.linalg.norm(g)
    stream = exploration_stream(plan, LOAD, HAND, rng, verify=directions)
    states = []
    for stamp, label in stream.labels:
        if "/" in label:  # 10 joint states over each window, at its pose
            q = dict(zip(arm, joints[label.split("/", 1)[1]], strict=True)) | fingers
            states += [(stamp + k * 20_000_000, label, q) for k in range(10)]
    return stream, states, robot


def test_kinematic_gravity_per_window_tightens_the_com():
    """The same stream fitted with the joints' gravity and without: the kinematic fit is
    right and its COM sigma along gravity is ~0.6x the wrench-only one."""
    stream, states, robot = kinematic_stream(np.random.default_rng(8))
    wrenches = fed(stream).solve()
    ex = Exploration(information="kinematics", robot=robot)
    for stamp, _, q in states:
        ex.add_joint_state(stamp, list(q), list(q.values()))
    kinematic = fed(stream, ex).solve()
    assert kinematic.status == OK and kinematic.information == "kinematics", kinematic.reason
    est = kinematic.estimate
    assert abs(est.mass - LOAD.mass) < 4 * est.sigma_mass
    assert np.all(np.abs(est.com - LOAD.com) < 4 * est.sigma_com)
    ratio = est.sigma_com / wrenches.estimate.sigma_com
    assert np.all(ratio < 0.7) and ratio[2] > 0.5, ratio
    assert kinematic.as_dict()["information"] == "kinematics"


def test_kinematics_without_a_robot_model_or_joint_states_says_why():
    stream, states, robot = kinematic_stream(np.random.default_rng(9))
    no_model = fed(stream, Exploration(information="kinematics")).solve()
    assert no_model.status == WARN and no_model.information == "wrenches"
    assert "no robot model" in no_model.reason
    paper = fed(stream, Exploration("two_pose", information="kinematics", robot=robot)).solve()
    assert paper.information == "wrenches" and paper.status == OK  # two_pose: the wrenches
    ex = Exploration(information="kinematics", robot=robot)
    for stamp, label, q in states:
        if label != "object/home":  # none for this window
            ex.add_joint_state(stamp, list(q), list(q.values()))
    partial = fed(stream, ex).solve()
    assert partial.status == WARN and "left out: no joint state within 0.1 s" in partial.reason
    assert [w.pose for w in partial.windows] == ["tilt_x+", "tilt_x-", "tilt_y+", "tilt_y-"]


def test_each_joint_is_taken_from_the_publishers_that_name_it_in_any_arrival_order():
    """An arm's publisher and a gripper's (a third of its rate, its own stamps), each
    naming its own joints: each window takes each joint from the messages that name it,
    as from one publisher of every joint, and the estimate does not depend on how the
    two publishers' messages interleaved (the node's and the bag's orders may differ)."""
    from conftest import PANDA

    stream, states, robot = kinematic_stream(np.random.default_rng(8))
    fingers = list(PANDA.gripper_joints)
    arm = [(t, [n for n in q if n not in fingers], [v for n, v in q.items() if n not in fingers])
           for t, _, q in states]  # fmt: skip
    gripper = [(t + 7_000_000, fingers, [0.04, 0.04]) for t, _, _ in states[::3]]
    orders = (sorted(arm + gripper, key=lambda m: m[0]), arm + gripper, gripper[::-1] + arm)
    solutions = []
    for order in orders:
        ex = Exploration(information="kinematics", robot=robot)
        for message in order:
            assert ex.add_joint_state(*message)
        solutions.append(fed(stream, ex).solve())
    first = solutions[0]
    assert first.status == OK and first.information == "kinematics", first.reason
    for other in solutions[1:]:
        assert other.estimate.mass == first.estimate.mass
        assert other.estimate.com.tolist() == first.estimate.com.tolist()
    whole = Exploration(information="kinematics", robot=robot)
    for stamp, _, q in states:
        whole.add_joint_state(stamp, list(q), list(q.values()))
    one = fed(stream, whole).solve().estimate
    np.testing.assert_allclose(first.estimate.com, one.com, rtol=1e-12, atol=1e-15)
    assert first.estimate.mass == pytest.approx(one.mass, rel=1e-12)
    # the gripper's messages alone give no window its arm; a malformed one is refused
    ex = Exploration(information="kinematics", robot=robot)
    assert not ex.add_joint_state(0, fingers, [0.04])
    for message in gripper:
        ex.add_joint_state(*message)
    alone = fed(stream, ex).solve()
    assert alone.status == ERROR and alone.reason.startswith("no windows to fit")
    assert "window 'object/home': the joint states lack 'panda_joint1'" in alone.reason


def test_a_run_lacks_its_input_until_each_stream_passes_its_done():
    """The estimator solves a run once its input up to ``done`` has come: the wrenches,
    and for a kinematic fit the joint states of every joint that moves the sensor, each
    publisher's stream on its own. An arm's stream that lags (its gripper's and the
    sensor's past ``done``) is named until it passes; the gripper's joints are not waited
    for, nor any joint by a fit of the wrenches alone."""
    from conftest import PANDA

    stream, states, robot = kinematic_stream(np.random.default_rng(8))
    done = next(t for t, label in stream.labels if label == "done")
    fingers = list(PANDA.gripper_joints)
    ex = Exploration(information="kinematics", robot=robot)
    assert ex.lacking(done) == "the wrenches (up to none)"
    fed(stream, ex)
    assert ex.lacking(done) == "the joint states of the joints that move the sensor (up to none)"
    ex.add_joint_state(done + 1, fingers, [0.04, 0.04])  # the gripper's, past done
    for stamp, _, q in states:  # the arm's, up to its last window
        ex.add_joint_state(stamp, [n for n in q if n not in fingers],
                           [v for n, v in q.items() if n not in fingers])  # fmt: skip
    last = max(t for t, _, _ in states)
    assert last < done and ex.joint_states_until(robot.chain_names) == last
    assert ex.lacking(done) == (
        f"the joint states of the joints that move the sensor (up to t={last * 1e-9:.3f} s)"
    )
    arm = dict(states[-1][2])
    ex.add_joint_state(done, [n for n in arm if n not in fingers],
                       [v for n, v in arm.items() if n not in fingers])  # fmt: skip
    assert ex.lacking(done) == ""
    assert fed(stream, Exploration(robot=robot)).lacking(done) == ""  # the wrenches alone


def test_an_exploration_without_labels_solves_to_no_windows():
    ex = Exploration()
    ex.add_samples([1, 2, 3], np.zeros((3, 6)), "ft_sensor")
    assert ex.spans() == {} and ex.segments() == []
    solution = ex.solve(until_ns=4)
    assert solution.status == ERROR and solution.reason.startswith("no windows")


def kinematic_exploration(stream, states, robot) -> Exploration:
    ex = Exploration(information="kinematics", robot=robot)
    for stamp, _, q in states:
        ex.add_joint_state(stamp, list(q), list(q.values()))
    return fed(stream, ex)


def test_a_verification_window_is_checked_against_the_fit_and_a_push_is_flagged():
    """The choreography's verification pose (20 deg about the sensor's diagonal): its
    compensated wrench is within the noise; with a push of 8 sigma of the window mean
    along x it is a WARN that names it, and the estimate is withheld (not usable). The
    wrenches alone leave the window unchecked and say why, without a WARN."""
    stream, states, robot = kinematic_stream(np.random.default_rng(12), verify=True)
    solution = kinematic_exploration(stream, states, robot).solve()
    assert solution.status == OK and solution.usable, solution.reason
    (check,) = solution.verifications
    assert check.pose == "diagonal" and check.passed
    assert check.allowed == pytest.approx(4.033, abs=1e-3)  # sqrt of chi2(3) at 1e-3
    assert np.all(np.abs(check.wrench) < 4.5 * check.sigma)
    assert np.all(check.sigma > np.sqrt(np.diag(check.noise)))  # the prediction's share
    (line,) = verification_lines(dict(solution.diagnostic_values()))
    assert line.startswith("verification 'diagonal': f (") and "(4.03 allowed)" in line
    assert [w.pose for w in solution.windows] == [
        "home",
        "tilt_x+",
        "tilt_x-",
        "tilt_y+",
        "tilt_y-",
    ]

    labels = dict((label, stamp) for stamp, label in stream.labels)
    start = labels["verify/diagonal"]
    pushed_wrenches = stream.wrenches.copy()
    inside = (stream.stamps >= start) & (stream.stamps < labels["done"])
    pushed_wrenches[inside, 0] += 8 * np.sqrt(check.noise[0, 0])
    pushed = Stream(stream.stamps, pushed_wrenches, stream.labels)
    flagged = kinematic_exploration(pushed, states, robot).solve()
    assert flagged.status == WARN and not flagged.usable
    assert "verification at 'diagonal'" in flagged.reason
    assert "does not hold beyond its poses" in flagged.reason

    wrenches = fed(stream).solve()
    assert wrenches.status == OK and not wrenches.verifications
    assert "information 'kinematics'" in wrenches.unverified


def test_before_a_window_label_only_the_lead_in_is_kept():
    """A node that only compensates (no exploration running) keeps a bounded buffer: the
    last IDLE_KEEP s of samples and joint states; once a window label came, everything."""
    from com_core.estimation.runs.inbox import IDLE_KEEP

    ex = Exploration()
    stamps = np.arange(0, 30_000_000_000, 1_000_000)  # 30 s at 1 kHz
    ex.add_samples(stamps, np.zeros((len(stamps), 6)), "ft_sensor")
    ex.add_joint_state(0, ["j"], [0.0])
    ex.add_label(int(stamps[-1]), "moving")  # a label that opens no window
    ex.forget_idle()
    assert ex.sample_count == round(IDLE_KEEP * 1000) + 1 and not ex._joint_states
    ex.add_label(int(stamps[-1]), "object/home")
    ex.add_samples(
        stamps[-1] + np.arange(1, 20_001) * 1_000_000, np.zeros((20_000, 6)), "ft_sensor"
    )
    ex.forget_idle()
    assert ex.sample_count == round(IDLE_KEEP * 1000) + 1 + 20_000  # a window is open


def test_a_wrench_of_the_opposite_sign_gives_the_same_estimate_with_wrench_sign():
    """A driver that publishes the wrench the sensor exerts on the load: with the estimator's
    ``wrench_sign`` -1 the estimate is the one of the usual sign, to the bit. Without it,
    the kinematics (gravity known) find the load pulled up: no estimate."""
    stream, states, robot = kinematic_stream(np.random.default_rng(8))

    def fed_with_kinematics(exploration: Exploration, sign: float) -> Exploration:
        exploration.add_samples(stream.stamps, sign * stream.wrenches, "ft_sensor")
        for stamp, label in stream.labels:
            exploration.add_label(stamp, label)
        for stamp, _, q in states:
            exploration.add_joint_state(stamp, list(q), list(q.values()))
        return exploration

    def kinematic(**options) -> Exploration:
        return Exploration(information="kinematics", robot=robot, **options)

    usual = fed_with_kinematics(kinematic(), 1.0).solve()
    opposite = fed_with_kinematics(kinematic(wrench_sign=-1.0), -1.0).solve()
    assert usual.status == OK and opposite.status == OK, (usual.reason, opposite.reason)
    assert opposite.estimate.mass == usual.estimate.mass
    assert opposite.estimate.com.tolist() == usual.estimate.com.tolist()
    wrong = fed_with_kinematics(kinematic(), -1.0).solve()
    assert wrong.status != OK, wrong.reason


def test_the_wrenches_alone_weigh_the_bias_drift_between_tare_and_object():
    """The wrenches-only fit subtracts each pose's tare: a bias drifting at a rate r moves
    every tare-subtracted window by r times the time between them. Its covariance holds
    that share under the kinematic fit's prior (``BIAS_DRIFT_RATE``): with next to no
    noise and 3 s windows, a bias 2 prior sigmas of drift rate further at each window
    (on each axis in turn; held within a window, which would read a ramp as motion) moves
    the estimate by 2 g_k, and the variances are sum_k g_k^2 (to 10 %: first order, and
    the noise's share)."""
    from com_core.estimation.fits.known_gravity import BIAS_DRIFT_RATE
    from com_core.sensing.wrench_model import SensorModel

    plan = replace(PLAN, dwell=3.0, sensor=SensorModel.from_scalars(1e-4, 1e-5))
    stream = exploration_stream(plan, LOAD, HAND, np.random.default_rng(4))
    still = fed(stream).solve().estimate
    starts = np.array([stamp for stamp, _ in stream.labels] + [stream.stamps[-1] + 1])
    segment = np.searchsorted(starts, stream.stamps, side="right") - 1
    middles = (starts[:-1] + starts[1:]) / 2 * 1e-9  # s, each segment's
    gains = []
    for axis, sigma in enumerate(np.repeat(BIAS_DRIFT_RATE, 3)):
        drifting = stream.wrenches.copy()
        drifting[:, axis] += 2.0 * sigma * middles[segment.clip(0)]
        moved = fed(replace(stream, wrenches=drifting)).solve().estimate
        gains.append(np.array([moved.mass - still.mass, *(moved.com - still.com)]) / 2.0)
    variance = np.sum(np.square(gains), axis=0)
    np.testing.assert_allclose(variance, np.diag(still.cov), rtol=0.1)
