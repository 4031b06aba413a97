"""The options of ``pmr-ros sweep`` as a table (:mod:`.arguments`), in the order ``--help`` lists them."""

from __future__ import annotations

import os

from . import nonnegative_int, number, positive_float, positive_int
from .arguments import FORCE, QUIET, config_option, option

__all__ = ["DEFAULT_OUT", "GRID", "OPTIONS"]

DEFAULT_OUT = "out/sweep"
"""Where a sweep writes by default."""

GRID = "nu grid (--nu or a range)"
"""The heading of the nu grid's options."""

OPTIONS = (
    config_option(),
    option(
        "--out",
        metavar="DIR",
        default=DEFAULT_OUT,
        help=f"folder of results.csv, sweep.json and, by default, the report (default: {DEFAULT_OUT})",
    ),
    option("--nu", metavar="LIST", help="comma-separated nu values, e.g. 1,2.25,5 (overrides the range)", group=GRID),
    option("--nu-start", type=number, default=1.0, metavar="X", help="first nu (default: 1)", group=GRID),
    option("--nu-stop", type=number, default=10.0, metavar="X", help="last nu, included (default: 10)", group=GRID),
    option("--nu-step", type=number, default=0.25, metavar="X", help="nu step (default: 0.25)", group=GRID),
    option(
        "--elements",
        default="G11,G21",
        metavar="LIST",
        help="elements whose time constant is swept, one sweep each (default: G11,G21)",
    ),
    option("--seeds", type=positive_int, default=5, metavar="N", help="seeds per (nu, scenario) (default: 5)"),
    option(
        "--methods",
        "--method",
        dest="methods",
        default="classic",
        metavar="LIST",
        help="diagnosis methods applied to every run, side by side in the report: classic, parametric "
        "(default: classic, the paper's study; classic,parametric adds the parametric fit, about 1.3x the time)",
    ),
    option(
        "--first-seed",
        type=nonnegative_int,
        metavar="S",
        help="seeds are S, S+1, ... (default: run.seed of the config)",
    ),
    option(
        "--samples",
        type=positive_int,
        metavar="N",
        help="closed-loop samples per run (default: run.samples of the config)",
    ),
    option(
        "--jobs",
        type=positive_int,
        default=os.cpu_count() or 1,
        metavar="N",
        help="worker processes (default: the number of cores)",
    ),
    option(
        "--scheduler",
        metavar="ADDRESS",
        help="run the points on the Dask distributed cluster of this scheduler (e.g. tcp://10.0.0.5:8786) "
        "instead of --jobs local processes; the workers need pmr_ros installed; the CSV is the same",
    ),
    option(
        "--connect-timeout",
        type=positive_float,
        default=None,
        metavar="S",
        help="--scheduler: give up when the scheduler has not answered in S seconds (default: 5)",
    ),
    FORCE.but(help="start afresh in an --out folder that holds an earlier sweep"),
    option(
        "--resume",
        action="store_true",
        help="continue an interrupted sweep in --out: skip the runs already in results.csv",
    ),
    option(
        "--report",
        metavar="FILE",
        help="markdown report to write; figures go to figures/ beside it (default: DIR/reproduction.md)",
    ),
    option("--no-report", action="store_true", help="only write results.csv"),
    option("--report-only", action="store_true", help="do not simulate: rebuild the report from DIR/results.csv"),
    QUIET,
)
"""The options of ``pmr-ros sweep``, in the order ``--help`` lists them."""
