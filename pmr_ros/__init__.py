"""pmr_ros: model-plant mismatch diagnosis for MPC with the plant-model ratio."""

from ._blas import limit_blas_threads
from ._version import package_version

limit_blas_threads()  # before anything of pmr_ros imports numpy (see pmr_ros._blas)

__version__ = package_version()
"""The version in package.xml (see :mod:`pmr_ros._version`)."""
