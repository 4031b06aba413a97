"""pmr_ros: model-plant mismatch diagnosis for MPC with the plant-model ratio.

The front door (``docs/api.md``)::

    import pmr_ros

    run = pmr_ros.simulate(samples=8192)  # the shipped Wood-Berry column, its mismatch injected
    diagnosis = pmr_ros.diagnose(run.record.r, run.record.u, run.record.y, config=run.config)
    for element in diagnosis:
        print(element.name, element.verdict)

``load_config``, ``simulate``, ``diagnose`` (arrays), ``diagnose_bag`` (a
rosbag2 bag), ``diagnose_file`` (a historian CSV or Parquet export) and the
types they take and give.  The names load on first use, so ``import pmr_ros``
stays light (no numpy, no rclpy) for the nodes and the console scripts.
"""

from __future__ import annotations

from ._blas import limit_blas_threads
from ._lazy import lazy_exports
from ._version import package_version

limit_blas_threads()  # before anything of pmr_ros imports numpy (see pmr_ros._blas)

__version__ = package_version()
"""The version in package.xml (see :mod:`pmr_ros._version`)."""

_WHERE = {
    "load_config": "api",
    "simulate": "api",
    "diagnose": "api",
    "diagnose_bag": "api",
    "diagnose_file": "api",
    "Simulation": "api",
    "PmrConfig": "config",
    "Record": "core.records",
    "TransferMatrix": "core.sim.model",
    "Diagnosis": "core.results",
    "ElementDiagnosis": "core.results",
    "ElementModel": "core.results",
    "ClassicResult": "core.results",
    "ParametricResult": "core.results",
    "DataQuality": "core.results",
}
"""Each name of the front door -> the module that defines it (imported on first use)."""

__all__ = ["__version__", *_WHERE]


__getattr__, __dir__ = lazy_exports(__name__, _WHERE, __all__)
