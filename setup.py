"""ament_python package setup for fbcc_ros."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = "fbcc_ros"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*"]),
    # The iiwa URDF travels with the code that loads it, and is also installed to share/ for
    # robot_state_publisher and visualisers.
    package_data={PACKAGE: ["urdf/*.urdf", "ros/*.xml"]},
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/config", glob("config/*.yaml")),
        (f"share/{PACKAGE}/config/scenarios", glob("config/scenarios/*.yaml")),
        (f"share/{PACKAGE}/config/profiles", glob("config/profiles/*.yaml")),
        (f"share/{PACKAGE}/launch", glob("launch/*.launch.py")),
        (f"share/{PACKAGE}/urdf", glob(f"{PACKAGE}/urdf/*.urdf")),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="fbcc_ros maintainers",
    maintainer_email="maintainers@fbcc-ros.dev",
    description="Feature-Based Compliance Control for peg-in-hole assembly (ROS 2 Jazzy).",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "fbcc-bench = fbcc_ros.cli.bench:main",
            "fbcc-maps = fbcc_ros.cli.maps:main",
            "fbcc-mapping-study = fbcc_ros.cli.mapping_study:main",
            "fbcc-sim = fbcc_ros.cli.sim:main",
            "fbcc-montecarlo = fbcc_ros.cli.montecarlo:main",
            "fbcc-kinematics = fbcc_ros.cli.kinematics:main",
            "fbcc-calibrate = fbcc_ros.cli.calibrate:main",
            "fbcc-report = fbcc_ros.cli.report:main",
            "fbcc-recover = fbcc_ros.cli.recover:main",
            "fbcc_bringup = fbcc_ros.nodes.bringup:main",
            "dynamic_compensation = fbcc_ros.ros.process:dynamic_compensation",
            "kinematics = fbcc_ros.ros.process:kinematics",
            "fbcc_controller = fbcc_ros.ros.process:fbcc_controller",
            "mock_cell = fbcc_ros.ros.process:mock_cell",
            "fbcc_record = fbcc_ros.ros.process:fbcc_record",
            "fbcc_replay = fbcc_ros.nodes.fbcc_replay:main",
        ],
    },
)
