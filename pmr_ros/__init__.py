"""pmr_ros: model-plant mismatch diagnosis for MPC with the plant-model ratio."""

from ._version import package_version

__version__ = package_version()
"""The version in package.xml (see :mod:`pmr_ros._version`)."""
