"""What a strain-gauge sensor's hysteresis does on the ways between windows, read at every
step as the sim node reads it, against what the fit at rest weighs.

    source ./env.sh && python bench/hysteresis_ways.py [--robot panda] [--mass 0.5]
        [--seeds 0,1,2,3] [--profile xarm_ft]

In process, no ROS: the sequencer's default static pass (``motion.record_static``'s: a
tare pass, the grasp, the object pass) with the sensor read at every step of every move,
the grasp and the settles too, as the nodes read it, where ``bench/motion.py`` keeps the
readings of the windows and the settles only (its gauges follow every step). The sim
knows the load and the gauges' state at every step; the fit (``FitSetup``, told the
sensor's band) knows the readings. Per way between two windows and axis: the load's own
total variation beyond what ``travel`` measures from the readings, in half-widths of its
deadband (what rings within the noise); the true increment of the state's first-order
residual (from a state started in the middle of its band along the same loads) over the
sigma the fit would weigh for it were its move beyond the first order not taken off
(``hysteresis_cov``), and what that move leaves of it over the sigma the fit weighs for
what is left (``BEYOND_LEFT``): the move read from the readings as the fit reads it
(``Hysteresis.beyond_first_order``), but from where the twin started, which the sim
knows (the fit's start offset takes the rest, the model being linear in it); and the share each
window keeps of the state's offset where the run starts, or after the contact, the fit's
(``start_memory`` of the travel measured) against the truth's. A way through contact
(the grasp) is weighed at the most it can move the state and leaves it anywhere in its
band: the twin starts from the middle again after it, as the fit's offset does.
"""

from __future__ import annotations

import argparse
import copy
from dataclasses import replace

import numpy as np
from motion import SETTLE, STATIC_PLAN, TARE_DWELL

from com_core.contract import OBJECT_PREFIX, TARE_PREFIX
from com_core.estimation.fits.known_gravity import Observation
from com_core.estimation.fits.windows import Window
from com_core.estimation.runs.fit_setup import FitSetup
from com_core.robot.choreography import Choreography
from com_core.robot.config import read_robot_config
from com_core.sensing.hysteresis import Hysteresis, follow, reach, travel
from com_core.sensing.sensor_profiles import PROFILES
from wrench_sim.config import SimConfig
from wrench_sim.joint_torques import wrench_in
from wrench_sim.physics import ArmWorld
from wrench_sim.sensor import profile_sensor

MOVE, GRASP_MOVE, GRIP = 1.0, 3.0, 0.5  # s: a move between poses, to the stand and back


def read_pass(robot: str, mass: float, seed: int, profile) -> dict:
    """The static pass of a box of ``mass`` kg on ``robot``, sensor ``seed`` of
    ``profile``, read at every step: per step the load, the reading and the state of
    the gauges and of a twin started in the middle of its band, and the window it is
    in ("" on the way)."""
    config = read_robot_config(robot)
    world = ArmWorld(SimConfig(robot=config, object_shape="box", object_mass=mass, seed=seed))
    try:
        sensor = profile_sensor(profile, seed=seed, serial=seed, world=world)
        gauges = sensor.gauges
        assert gauges is not None, "the profile has no hysteresis"
        twin = copy.deepcopy(gauges)
        twin.state = np.zeros(6)
        steps: dict[str, list] = {"load": [], "reading": [], "state": [], "twin": [], "in": []}

        def until(end: float, label: str = "") -> None:
            while world.time < end:
                world.step()
                load = wrench_in(world, sensor.joint_torques)
                steps["reading"].append(sensor.read(load, world.time))
                twin.apply(load, world.time)
                steps["load"].append(load)
                steps["state"].append(gauges.state.copy())
                steps["twin"].append(twin.state.copy())
                steps["in"].append(label)

        def window(label: str, joints, dwell: float, seconds: float = MOVE) -> None:
            until(world.command_move(joints, seconds) + SETTLE)
            if seconds == GRASP_MOVE:  # after the contact: the twin from the middle again
                twin.state = np.zeros(6)
            until(world.time + dwell, label)

        until(world.time + SETTLE)
        poses = Choreography.of(config, world.urdf_text).pose_joints(STATIC_PLAN)
        for name, joints in poses:
            window(TARE_PREFIX + name, joints, TARE_DWELL)
        until(world.command_move(config.pick_joints, GRASP_MOVE) + SETTLE)
        world.command_gripper(config.gripper_closed)
        until(world.time + GRIP)
        for i, (name, joints) in enumerate(poses):
            window(OBJECT_PREFIX + name, joints, STATIC_PLAN.dwell, GRASP_MOVE if not i else MOVE)
        if not world.object_held:
            raise RuntimeError("the grasp failed")
        return {key: np.array(value) for key, value in steps.items()}
    finally:
        world.close()


def ways(steps: dict, hysteresis: Hysteresis) -> dict:
    """Per window after the first (n - 1,): the way's label, whether it is through
    contact, and per axis (n - 1, 6) the hidden travel in half-widths, the true
    increment over the sigma the fit weighs for it without ``Observation.beyond``, what
    it leaves less the move beyond its first order over the sigma weighed with it, and the
    start's share the fit and the truth keep."""
    labels = [label for label in dict.fromkeys(steps["in"]) if label]
    index = [np.flatnonzero(steps["in"] == label) for label in labels]
    middles = [i[len(i) // 2] for i in index]
    readings = steps["reading"] / hysteresis.gain()
    contact = next(k for k, label in enumerate(labels) if label.startswith(OBJECT_PREFIX))
    observations, hidden, beyond = [], [], [np.zeros(6)]
    for k, (label, i) in enumerate(zip(labels, index, strict=True)):
        window = Window(label, readings[i].mean(axis=0), np.eye(6), len(i))
        loaded = label.startswith(OBJECT_PREFIX)
        known = {}
        if k:
            a, b = middles[k - 1], middles[k] + 1
            known = {"travel": travel(readings[a:b]), "reach": reach(readings[a:b])}
            own = np.abs(np.diff(steps["load"][a:b], axis=0)).sum(axis=0)
            hidden.append((own - known["travel"]) / follow(readings[a:b])[1])
            first = index[contact][0] if k >= contact else 0  # where the twin started
            beyond.append(hysteresis.beyond_first_order(readings[first:b])[-1])
        observations.append(Observation(window, np.eye(3), loaded, 0, float(k), **known))
    told = FitSetup(hysteresis=hysteresis)
    n = len(observations)

    def sigma(obs: list[Observation]) -> np.ndarray:
        return np.sqrt(np.diag(told.hysteresis_cov(obs))[: 6 * n]).reshape(n, 6)[1:]

    taken = [replace(o, beyond=moved) for o, moved in zip(observations, beyond, strict=True)]
    held = [o.load for o in observations]
    starts = [0] + [k for k in range(1, n) if held[k] != held[k - 1]]
    latest = [max(j for j in starts if j <= k) for k in range(n)]  # the offset each keeps
    designs = [o.nuisance for o in told.with_hysteresis(observations)]
    kept = np.array([np.diag(designs[k][:, 6 * (n + starts.index(latest[k])) :][:, :6])
                     for k in range(n)])  # fmt: skip
    d = hysteresis.gain_deficit()
    residual = np.array([(steps["twin"][i] + d * steps["load"][i]).mean(axis=0) for i in index])
    offset = np.array([(steps["state"][i] - steps["twin"][i]).mean(axis=0) for i in index])
    increment = np.diff(residual, axis=0)
    return {
        "label": labels[1:],
        "contact": [k in starts for k in range(1, n)],
        "hidden": np.array(hidden),
        "z": increment / sigma(observations),
        "z_left": (increment - np.diff(beyond, axis=0)) / sigma(taken),
        "kept": kept[1:],
        "true_kept": offset[1:] / offset[latest[1:]],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="panda")
    parser.add_argument("--mass", type=float, default=0.5)
    parser.add_argument("--seeds", default="0,1,2,3")
    parser.add_argument("--profile", default="xarm_ft", choices=sorted(PROFILES))
    args = parser.parse_args()
    profile = PROFILES[args.profile]
    hysteresis = Hysteresis.stated(profile.hysteresis, profile.limit_f, profile.limit_tau)
    assert hysteresis is not None, f"{args.profile} has no hysteresis"
    np.set_printoptions(precision=2, suppress=True, linewidth=160)
    found = []
    for seed in (int(s) for s in args.seeds.split(",")):
        out = ways(read_pass(args.robot, args.mass, seed, profile), hysteresis)
        found.append(out)
        print(f"sensor {seed}: hidden travel (half-widths), increment / sigma; fx fy fz tx ty tz")
        for k, label in enumerate(out["label"]):
            kind = "contact" if out["contact"][k] else "       "
            print(f"  {label:18s} {kind}  hidden {out['hidden'][k]}  z {out['z'][k]}")
            print(f"  {'':27s} less beyond, z {out['z_left'][k]}")
    contact = np.concatenate([o["contact"] for o in found])
    hidden = np.concatenate([o["hidden"] for o in found])
    z = np.concatenate([o["z"] for o in found])
    kept = np.concatenate([o["kept"] for o in found])
    true_kept = np.concatenate([o["true_kept"] for o in found])
    print(f"\n{args.robot}, {args.mass:g} kg, {len(found)} sensors of {args.profile}:")
    for name, rows in (("between poses", ~contact), ("through contact", contact)):
        print(f"  {name:16s} hidden travel per axis, largest: {hidden[rows].max(axis=0)}")
    between = z[~contact]  # through contact: weighed at the bound, the offset after it new
    print(
        f"  increment / sigma between poses, rms per axis: {np.sqrt(np.mean(between**2, axis=0))}"
    )
    print(f"  increment / sigma between poses, largest |.|:  {np.abs(between).max(axis=0)}")
    left = np.concatenate([o["z_left"] for o in found])[~contact]
    print(f"  less its move beyond the first order, over the sigma then weighed, rms per axis: "
          f"{np.sqrt(np.mean(left**2, axis=0))}")  # fmt: skip
    print(f"  the same, largest |.|: {np.abs(left).max(axis=0)}")
    off = np.abs(kept - true_kept).max(axis=0)
    print(f"  the start's share kept, the fit's less the truth's, largest |.|: {off}")


if __name__ == "__main__":
    main()
