"""ament_python package setup for pmr_ros (also installs with plain pip)."""

import xml.etree.ElementTree as ElementTree
from glob import glob
from pathlib import Path

from setuptools import find_packages, setup

PACKAGE = "pmr_ros"


def package_xml_version() -> str:
    """The version in package.xml, the one place it is written (ROS convention)."""
    version = ElementTree.parse(Path(__file__).resolve().parent / "package.xml").getroot().findtext("version")
    if not version or not version.strip():
        raise SystemExit("pmr_ros setup.py: package.xml has no <version>")
    return version.strip()


setup(
    name=PACKAGE,
    version=package_xml_version(),
    packages=find_packages(exclude=["test", "test.*"]),
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/config", glob("config/*.yaml") + glob("config/*.csv")),
        (f"share/{PACKAGE}/msg_defs", glob("msg_defs/*")),
    ],
    python_requires=">=3.10",
    install_requires=[
        "numpy>=1.24,<3",
        "scipy>=1.10,<2",
        "osqp>=1.0,<2",
        "rosbags>=0.10,<0.12",
        # Reading an MCAP bag whose recorder was killed (no summary, no metadata.yaml).
        "mcap>=1.1,<2",
        "PyYAML>=6,<7",
        # One BLAS thread even when numpy was imported first (pmr_ros._blas).
        "threadpoolctl>=3,<4",
    ],
    extras_require={
        # ROS 2 Jazzy from PyPI wheels; not needed by the batch core.
        # ament_index_python: pmr_ros.resources finds a colcon workspace's share/pmr_ros with it.
        "ros": [
            "ros-jazzy-rclpy[fastrtps]>=7.1,<8",
            "ros-jazzy-common-interfaces>=5.3,<6",
            "ros-jazzy-ament-index-python>=1.8,<2",
        ],
        # mypy checks pmr_ros (test.sh), PyYAML's types come as a stub package;
        # python-control: test_model checks the FOPTD responses against it.
        "test": [
            "pytest>=8",
            # test.sh runs the suite on every core (CI has two).
            "pytest-xdist>=3.5,<4",
            "ruff>=0.6",
            "mypy>=1.10",
            "types-PyYAML>=6",
            "matplotlib>=3.7",
            "mcap-ros2-support>=0.5,<1",
            "control>=0.10,<0.11",
            # test_sweep starts a local Dask cluster (the cluster extra below)
            "distributed>=2024.1",
        ],
        # `pmr-ros sweep --scheduler ADDRESS`: the sweep's points on a Dask distributed cluster.
        "cluster": ["distributed>=2024.1"],
        # Figures of `pmr-ros sweep` (imported lazily; the core does not need it).
        "plot": ["matplotlib>=3.7"],
        # `pmr-ros diagnose FILE.csv|.parquet` (historian exports) and `--report DIR` (HTML with figures);
        # imported lazily, so the nodes and the bag path run without them.  pandas 2 and 3 (its copy-on-write:
        # arrays taken from pandas are copied before they are written; the data tests pass under both).
        "data": ["pandas>=2,<4", "pyarrow>=14", "matplotlib>=3.7", "jinja2>=3.1,<4"],
    },
    zip_safe=True,
    maintainer="pmr_ros developers",
    maintainer_email="dev@pmr-ros.invalid",
    description="Model-plant mismatch diagnosis for MPC with the plant-model ratio, as ROS 2 nodes.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            # pmr_ros.entry: Ctrl-C is taken from the first instant, while the modules are still importing.
            "pmr-ros = pmr_ros.entry:pmr_ros",
            # The ROS 2 node set (--ros-args --params-file config/wood_berry.yaml).
            "wood_berry_plant = pmr_ros.entry:wood_berry_plant",
            "prbs_setpoint = pmr_ros.entry:prbs_setpoint",
            "mpc_controller = pmr_ros.entry:mpc_controller",
            "pmr_diagnostician = pmr_ros.entry:pmr_diagnostician",
            # The diagnostician as a managed node (ros2 lifecycle set ... configure / activate).
            "pmr_diagnostician_lifecycle = pmr_ros.entry:pmr_diagnostician_lifecycle",
        ],
    },
)
