from setuptools import find_packages, setup

PACKAGE = "wrench_sim"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    description=(
        "pybullet simulation of an arm with a wrist F/T sensor (Franka Panda, UFACTORY "
        "xArm6, or any arm a robot configuration describes), publishing wrenches, joint "
        "states and sim time"
    ),
    license="Apache-2.0",
    entry_points={"console_scripts": ["sim_node = wrench_sim.sim_node:main"]},
)
