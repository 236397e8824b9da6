"""com_core installs with pip (into the venv) and with colcon (ament_python) alike."""

from setuptools import find_packages, setup

PACKAGE = "com_core"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(include=[PACKAGE, f"{PACKAGE}.*"]),
    package_data={PACKAGE: ["py.typed", "config/*.yaml", "config/*.urdf", "runtime/*.xml"]},
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
    ],
    install_requires=["numpy", "PyYAML"],
    python_requires=">=3.10",
    zip_safe=True,
    description="ROS-free estimation core for object mass and centre of mass from F/T wrenches",
    license="Apache-2.0",
)
