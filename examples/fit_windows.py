"""Static windows to mass and COM: the empty hand's tare subtracted, then the
maximum-likelihood fit (``com_core.estimation``).

A 0.8 kg hand holds a 0.25 kg object at home and tilted 30 deg either way about the
sensor's x and y axes; each window is 500 samples (0.5 s at 1 kHz) of white noise,
0.1 N and 0.005 N m per sample. Prints the estimate with its 1-sigma and the truth::

    python examples/fit_windows.py
"""

import numpy as np

from com_core.estimation.fits import ml, reduce_window, subtract_tare
from com_core.sensing import gravity_in_sensor, gravity_wrench, rotation_about

TILT = np.radians(30.0)
SIGMA = np.array([0.1, 0.1, 0.1, 0.005, 0.005, 0.005])  # N, N m per sample
HAND = (0.8, (0.0, 0.0, 0.04))  # kg, m in the sensor frame
OBJECT = (0.25, (0.012, -0.006, 0.11))

rng = np.random.default_rng(0)
poses = {"home": np.eye(3)}
for axis in "xy":
    poses[f"tilt_{axis}+"] = rotation_about(axis, TILT)
    poses[f"tilt_{axis}-"] = rotation_about(axis, -TILT)


def window(pose: str, loads: list[tuple[float, tuple[float, ...]]]):
    """500 noisy samples of the loads' gravity wrench at ``pose``, reduced to their mean."""
    g = gravity_in_sensor(poses[pose])  # m/s^2 in the sensor frame
    wrench = sum(gravity_wrench(mass, com, g) for mass, com in loads)
    return reduce_window(pose, wrench + rng.normal(0.0, SIGMA, (500, 6)))


tares = [window(pose, [HAND]) for pose in poses]
objects = [window(pose, [HAND, OBJECT]) for pose in poses]
estimate = ml(subtract_tare(objects, tares))

com, sigma = estimate.com * 1e3, estimate.sigma_com * 1e3
print(f"mass {estimate.mass * 1e3:.2f} +- {estimate.sigma_mass * 1e3:.2f} g (truth 250.00)")
print(
    f"COM ({com[0]:.2f}, {com[1]:.2f}, {com[2]:.2f}) +- ({sigma[0]:.2f}, {sigma[1]:.2f}, "
    f"{sigma[2]:.2f}) mm (truth 12.00, -6.00, 110.00)"
)
print(f"chi2 {estimate.chi2:.1f} for {estimate.dof} dof (p = {estimate.p_value:.2f})")
