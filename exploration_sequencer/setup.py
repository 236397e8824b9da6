from setuptools import find_packages, setup

PACKAGE = "exploration_sequencer"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/config", ["config/real_robot.yaml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    description="Sequencer that tares, grasps and tilts to explore an object; records each run",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "sequencer_node = exploration_sequencer.sequencer_node:main",
            "demo = exploration_sequencer.demo:main",
        ]
    },
)
