"""The options of ``pmr-ros diagnose --window`` and ``--fleet`` as a table (:mod:`.arguments`)."""

from __future__ import annotations

from . import positive_float, positive_int
from .arguments import QUIET, Option, option

__all__ = ["MONITOR", "MONITOR_OPTIONS"]


MONITOR = "rolling windows (a monitor over a long record)"
"""The heading of ``pmr-ros diagnose``'s rolling-window options."""

MONITOR_OPTIONS = (
    option(
        "--window",
        metavar="W",
        help="diagnose every window of W samples, or of clock time with a unit (14d, 6h, 30min, 90s) when the data "
        "have time stamps; the JSON gains 'windows' and each element its 'onset' (when it began to move, step or "
        "drift); the table shows the last window",
        group=MONITOR,
    ),
    option(
        "--step",
        metavar="S",
        help="--window: the step between window ends, in the window's unit (default: a quarter of the window)",
        group=MONITOR,
    ),
    option(
        "--trend",
        metavar="FILE",
        help="--window: also write one row per window and element (estimates, 95 %% intervals, verdicts, data "
        "quality) to FILE.csv or FILE.parquet",
        group=MONITOR,
    ),
    option(
        "--jobs",
        type=positive_int,
        metavar="N",
        help="--window, --fleet: worker processes (default: the number of cores; 1: in this process)",
        group=MONITOR,
    ),
    option(
        "--scheduler",
        metavar="ADDRESS",
        help="--window, --fleet: run on the Dask distributed cluster of this scheduler (e.g. tcp://10.0.0.5:8786) "
        "instead of local processes; the results are the same",
        group=MONITOR,
    ),
    option(
        "--connect-timeout",
        type=positive_float,
        metavar="S",
        help="--scheduler: give up when the scheduler has not answered in S seconds (default: 5)",
        group=MONITOR,
    ),
    option(
        "--fleet",
        metavar="FLEET.yaml",
        help="diagnose a fleet of controllers (a list of entries: name, params, data; optional window, step): "
        "one summary ranked by control impact (else by decided mismatch over its tolerance), and with --report "
        "an index page linking every controller's report; a failing entry is listed as failed, the others run",
        group=MONITOR,
    ),
    Option(QUIET.flags, {**QUIET.settings, "help": "--window, --fleet: say nothing while the windows run"}, MONITOR),
)
"""The options of ``pmr-ros diagnose --window`` and ``--fleet``."""
