"""A payload file into the compensated wrench (``com_core.payload``): what the sensor
reads less the hand's and the object's gravity wrench and the bias, at any orientation.

A payload (as the estimator writes it after a run) goes to ``payload.yaml`` and the
control_toolbox and URDF files; read back, it turns readings that carry a 2 N push at
three orientations of the sensor into the push alone::

    python examples/compensate.py
"""

import tempfile
from pathlib import Path

import numpy as np

from com_core.payload import Payload, compensate, payload_wrench, read_payload, write_payload_files
from com_core.sensing import rotation_about

payload = Payload(
    mass=0.25,  # kg, the object
    com=[0.012, -0.006, 0.11],  # m, sensor frame
    cov=np.diag([0.3e-3, 0.2e-3, 0.2e-3, 0.4e-3]) ** 2,  # (mass, COM) covariance, kg and m
    hand_mass=0.8,
    hand_com=[0.0, 0.0, 0.04],
    bias=[0.3, -0.2, 0.1, 0.01, -0.02, 0.005],  # N, N m: the sensor's zero
    frame="ft_sensor",  # the wrenches' frame_id
    sensor_frame="panda_hand",  # the URDF frames the rotations relate
    base_frame="panda_link0",
    information="kinematics+mount",
)
with tempfile.TemporaryDirectory() as directory:
    written = write_payload_files(directory, payload)
    print("wrote", ", ".join(path.name for path in written))
    loaded = read_payload(Path(directory) / "payload.yaml", frame="ft_sensor")

push = np.array([2.0, 0.0, 0.0, 0.0, 0.0, 0.0])  # N, N m: a contact on the sensor's x
for angle in (0.0, 0.5, 1.0):  # rad about the base's x axis
    rotation = rotation_about("x", angle)  # R_base_sensor from forward kinematics
    reading = payload_wrench(loaded, rotation) + push
    contact = compensate(loaded, reading, rotation)
    print(
        f"{angle:.1f} rad: reads f {np.round(reading[:3], 3)} N -> contact "
        f"f {np.round(contact[:3], 6) + 0.0} N, tau {np.round(contact[3:], 6) + 0.0} N m"
    )
