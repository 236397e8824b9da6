"""An exploration in motion solved as the estimator and the replay solve it
(``Exploration.solve`` on ``motion/`` labels, ``estimation.motion_solution``), fed by the
simulator in process through the realistic sensor (no ROS)."""

from __future__ import annotations

import numpy as np
import pytest

from com_core.contract import DONE, MOTION_OBJECT, MOTION_TARE, MOTION_VERIFY, MOVING, OK, WARN
from com_core.estimation.cutting import motion_spans
from com_core.estimation.motion import compensated, load_vector, principal_moments
from com_core.estimation.motion_solution import joint_arrays
from com_core.estimation.settings import exploration_from
from com_core.planning.excitation import design_excitation
from com_core.robot.dynamics import inertial_parameters
from com_core.robot.model import RobotModel
from com_core.sensing.sensor_profiles import PROFILES
from wrench_sim.config import SimConfig
from wrench_sim.physics import ArmWorld
from wrench_sim.sensor import profile_sensor
from wrench_sim.studies import grasp, run_excitation

JOINT_EVERY = 10  # joint states at 100 Hz


def feed(exploration, world, sensor, label: str, seconds: float = 0.0, excitation=None):
    """Label the next ``seconds`` at rest, or ``excitation``, as ``label``, and feed its
    wrenches and joint states to ``exploration``; ``moving`` after it."""
    ns = lambda t: round(t * 1e9)  # noqa: E731
    exploration.add_label(ns(world.time + 1e-3), label)
    names = world.config.robot.arm_joints
    if excitation is None:
        end = world.time + seconds
        rows = []
        while world.time < end:
            world.step()
            rows.append((world.time, world.joint_state()[1][: len(names)],
                         sensor.read(world.wrench, world.time)))  # fmt: skip
        joint_times = [t for t, _, _ in rows][::JOINT_EVERY]
        positions = [q for _, q, _ in rows][::JOINT_EVERY]
        times, wrenches = [t for t, _, _ in rows], [w for _, _, w in rows]
    else:
        joint_times, positions, times, wrenches = run_excitation(
            world, excitation, sensor, JOINT_EVERY
        )
    exploration.add_samples([ns(t) for t in times], np.array(wrenches), ["ft_sensor"] * len(times))
    for t, q in zip(joint_times, positions, strict=True):
        exploration.add_joint_state(ns(t), names, list(q))
    exploration.add_label(ns(world.time), MOVING)


@pytest.fixture(scope="module")
def solved():
    """One run: the empty hand at rest and in motion, the grasp, the object's motion and
    another motion; solved from its labels."""
    profile = PROFILES["realistic"]
    sensor = profile_sensor(profile, seed=11, serial=11)
    world = ArmWorld(SimConfig(object_mass=0.5, seed=3))
    robot = world.config.robot
    model = RobotModel(world.urdf_text, robot.sensor_frame)
    design = dict(period=3.0, iterations=40)
    excitation = design_excitation(model, robot.home_joints, robot.arm_joints[-3:], **design)
    other = design_excitation(model, robot.home_joints, robot.arm_joints[-3:], seed=5, **design)
    exploration = exploration_from({"information": "kinematics"}, world.urdf_text)
    try:
        world.move_arm(robot.home_joints, 1.0)
        feed(exploration, world, sensor, "tare/home", 2.0)
        feed(exploration, world, sensor, MOTION_TARE, excitation=excitation)
        grasp(world)
        feed(exploration, world, sensor, MOTION_OBJECT, excitation=excitation)
        feed(exploration, world, sensor, MOTION_VERIFY, excitation=other)
        exploration.add_label(round(world.time * 1e9), DONE)
        truth = world.object_ground_truth(), world.inertia_ground_truth()[1]
        yield exploration, exploration.solve(), truth, world.urdf_text
    finally:
        world.close()


def test_a_motion_gives_mass_com_and_inertia_within_their_error_bars(solved):
    """Mass, COM and the six inertia elements within 4 of their sigmas of the truth; the
    principal moments within 4 sigma; the check along the other motion passes (its
    compensated rms near the prediction, not below the noise), and the solution says it
    came from motion."""
    _, solution, ((mass, com), inertia), _ = solved
    assert solution.status == OK, solution.reason
    assert solution.usable and solution.excitation == "motion"
    result = solution.motion
    truth = load_vector(inertial_parameters(mass, com, inertia))
    z = (result.object.load_vector() - truth) / np.sqrt(np.diag(result.load_cov))
    assert np.all(np.abs(z) < 4.0), z
    moments, sigma = principal_moments(result.inertia, result.load_cov[4:, 4:])
    true_moments = np.linalg.eigvalsh(inertia)
    assert np.all(np.abs(moments - true_moments) < 4 * sigma), (moments, true_moments, sigma)
    (check,) = solution.verifications
    assert check.passed and min(check.ratio) > 0.5 and max(check.ratio) < 1.2, check.ratio
    values = dict(solution.diagnostic_values())
    assert values["excitation"] == "motion" and len(values["inertia"].split(",")) == 6
    assert "principal moments (" in solution.reason


def test_a_load_that_changes_between_the_motions_fails_the_check(solved):
    """The verification motion read with 30 g more in the hand than the fits saw (a point
    mass 20 mm off the grasp's axis, its wrench along that motion added): the check
    fails and the solution is a WARN that is not usable."""
    exploration, _, _, urdf = solved
    stamps, wrenches = exploration.samples()
    (start, stop), *_ = motion_spans(exploration)[MOTION_VERIFY]
    robot = exploration.robot
    joint_times, positions = joint_arrays(exploration, robot, start - 10**9, stop + 10**9)
    inside = (stamps >= start) & (stamps < stop) & (stamps * 1e-9 < joint_times[-1] - 0.06)
    extra = inertial_parameters(0.03, np.array([0.02, 0.0, 0.1]), np.zeros((3, 3)))
    out = wrenches.copy()
    out[inside] = compensated(robot, -extra, np.zeros(6), 0.0, joint_times, positions,
                              stamps[inside] * 1e-9, wrenches[inside])  # fmt: skip
    shifted = exploration_from({"information": "kinematics"}, urdf)
    shifted.add_samples(stamps, out, ["ft_sensor"] * len(stamps))
    for stamp, label in exploration.labels:
        shifted.add_label(stamp, label)
    for stamp, joints in exploration.joint_states:
        shifted.add_joint_state(stamp, list(joints), list(joints.values()))
    solution = shifted.solve()
    assert solution.status == WARN and not solution.usable, solution.reason
    assert "verification along 'motion'" in solution.reason
