"""The numerical core, free of ROS and of configuration files, by subject.

``sim`` the model, the true plant, the excitation and the closed loop in
batch; ``mpc`` the controller; ``pmr`` the plant-model ratio diagnosis (classic
and parametric); ``loop`` what follows a verdict (control impact, corrected
model, judging a live update).  Every subject reads and writes the one data
record, :class:`~pmr_ros.core.records.Record`, and the result types of
:mod:`pmr_ros.core.results`.
"""

from __future__ import annotations

from .._lazy import lazy_exports

_WHERE = {
    "Record": "records",
    "Diagnosis": "results",
    "ElementDiagnosis": "results",
    "ElementModel": "results",
    "ClassicResult": "results",
    "ParametricResult": "results",
    "DataQuality": "results",
}
"""The types every subject shares -> their module (imported on first use); the subjects' own names are theirs."""

__all__ = [*_WHERE]


__getattr__, __dir__ = lazy_exports(__name__, _WHERE, __all__)
