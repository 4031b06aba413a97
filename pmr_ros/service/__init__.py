"""Orchestration shared by the nodes, the ``pmr-ros`` commands and the Python API (:mod:`pmr_ros.api`).

Each flow strings the layers below together once: ``closing`` the control
impact of a verdict and the corrected model it proposes (live node, ``run``,
``diagnose``), ``bag_diagnosis`` a bag diagnosed offline and compared with its
recorded verdicts, ``historian`` a CSV or Parquet export diagnosed,
``adapted_run`` the live model update of ``run --adapt``, ``batch_run`` ``run --batch``, ``refusal`` the error a
flow stops with.  The commands only parse arguments and print; the nodes only
convert messages and keep time.

The names below are imported when first used, so importing one module of
this package does not load the others.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

_WHERE = {
    "ADAPT_STALL_TIMEOUT_S": "adapted_run",
    "ADAPT_WINDOWS": "adapted_run",
    "Closed": "closing",
    "ClosedWindow": "closing",
    "EXIT_INSUFFICIENT": "refusal",
    "LIMITS": "historian",
    "ServiceError": "refusal",
    "TableDiagnosis": "historian",
    "adapt_config": "adapted_run",
    "adapt_parameters": "adapted_run",
    "adapted_report": "adapted_run",
    "close_and_write": "closing",
    "close_diagnosis": "closing",
    "close_window": "closing",
    "compare": "bag_diagnosis",
    "diagnose_bag": "bag_diagnosis",
    "diagnose_table": "historian",
    "judged_config": "bag_diagnosis",
    "limits_given": "historian",
    "model_file_text": "closing",
    "run_adapted": "adapted_run",
    "simulate_and_diagnose": "batch_run",
    "window_data": "bag_diagnosis",
    "window_signals": "bag_diagnosis",
}
"""Each public name -> the module of this package that defines it."""

__all__ = [
    "ADAPT_STALL_TIMEOUT_S",
    "ADAPT_WINDOWS",
    "Closed",
    "ClosedWindow",
    "EXIT_INSUFFICIENT",
    "LIMITS",
    "ServiceError",
    "TableDiagnosis",
    "adapt_config",
    "adapt_parameters",
    "adapted_report",
    "close_and_write",
    "close_diagnosis",
    "close_window",
    "compare",
    "diagnose_bag",
    "diagnose_table",
    "judged_config",
    "limits_given",
    "model_file_text",
    "run_adapted",
    "simulate_and_diagnose",
    "window_data",
    "window_signals",
]


__getattr__, __dir__ = lazy_exports(__name__, _WHERE, __all__)


if TYPE_CHECKING:
    from .adapted_run import (
        ADAPT_STALL_TIMEOUT_S,
        ADAPT_WINDOWS,
        adapt_config,
        adapt_parameters,
        adapted_report,
        run_adapted,
    )
    from .bag_diagnosis import compare, diagnose_bag, judged_config, window_data, window_signals
    from .batch_run import simulate_and_diagnose
    from .closing import Closed, ClosedWindow, close_and_write, close_diagnosis, close_window, model_file_text
    from .historian import LIMITS, TableDiagnosis, diagnose_table, limits_given
    from .refusal import EXIT_INSUFFICIENT, ServiceError
