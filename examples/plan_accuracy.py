"""A plan to its predicted sigma, and the dwell a target COM sigma asks for
(``com_core.planning``), before the arm moves.

The planner predicts the Cramer-Rao bound of the fit for a tilt plan and a sensor, and
inverts it: the shortest dwell per pose that meets a target. A tilt too small for the
target is refused with what would do::

    python examples/plan_accuracy.py
"""

from dataclasses import replace

from com_core.planning import Plan, dwell_for_target, predict
from com_core.sensing import SensorModel

plan = Plan(
    tilt=0.52,  # rad, about the sensor's x and y axes, both ways
    dwell=0.9,  # s per pose
    sensor=SensorModel.from_scalars(0.1, 0.005),  # N, N m per sample at 1 kHz
    mass_guess=0.1,  # kg
    com_guess=(0.01, 0.0, 0.11),  # m, sensor frame
)
print(f"as planned ({plan.duration():.1f} s): {predict(plan)}")
print(f"with the kinematics: {predict(plan, information='kinematics')}")

advice = dwell_for_target(plan, target_com_sigma=0.2e-3)
print(f"for 0.2 mm: {advice}")

small = replace(plan, tilt=0.05)
print(f"tilt 0.05 rad for 0.5 mm: {dwell_for_target(small, 0.5e-3, max_time=30.0)}")
