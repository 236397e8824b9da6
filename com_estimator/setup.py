from setuptools import find_packages, setup

PACKAGE = "com_estimator"

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
    description="Estimator node for object mass and COM from wrist F/T wrenches; bag replay",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "estimator_node = com_estimator.estimator_node:main",
            "replay = com_estimator.replay:main",
            "synthetic_exploration = com_estimator.synthetic_exploration:main",
        ]
    },
)
