"""The options of ``pmr-ros benchmark`` as a table (:mod:`.arguments`), in the order ``--help`` lists them."""

from __future__ import annotations

from . import positive_int
from .arguments import QUIET, option

__all__ = ["DEFAULT_OUT", "OPTIONS"]

DEFAULT_OUT = "out/benchmark"
"""Where a benchmark writes by default."""

SELECTION = "which runs of the scenario file (config/benchmark_scenarios.csv)"

OPTIONS = (
    option("--quick", action="store_true", help="only the quick subset: the first run of each Wood-Berry cell up to "
           "4,096 samples (4 runs)", group=SELECTION),
    option("--units", metavar="LIST", help="only these units, comma-separated: wood_berry, three_by_three, "
           "debutanizer, sparse_sixteen, and in routine operation (setpoint steps, MV dither) wood_berry_routine, "
           "debutanizer_routine (default: all)", group=SELECTION),
    option("--samples", metavar="LIST", help="only these record lengths, e.g. 2048,8192 (default: all five)",
           group=SELECTION),
    option("--runs-per-cell", type=positive_int, metavar="N", help="at most the first N runs of each unit, "
           "disturbance and length (default: all 26)", group=SELECTION),
    option("--scenarios", metavar="FILE", help="another scenario file of the same columns", group=SELECTION),
    option("--methods", metavar="LIST", default=None, help="only these methods, comma-separated: parametric, "
           "classic, partial_correlation, pem_oe, pem_bj (default: all)"),
    option("--pem-runs-per-cell", type=positive_int, metavar="N", help="the prediction-error peers (pem_oe, pem_bj: "
           "10-100x the others' CPU time) on only the first N runs of each cell (default: every run)"),
    option("--out", metavar="DIR", default=DEFAULT_OUT,
           help=f"folder of results.parquet and scores.csv (default: {DEFAULT_OUT})"),
    option("--report", metavar="FILE", help="the markdown report; figures go to figures/ beside it "
           "(default: DIR/benchmark.md)"),
    option("--export", metavar="DIR", help="also write the dataset: every run's r, u, y as Parquet, the models, "
           "labels.csv with the injected truth, SCHEMA.md"),
    option("--report-only", action="store_true", help="do not run: score every run DIR holds again (its journal "
           "DIR/runs, else DIR/results.parquet) and rewrite results.parquet, scores.csv and the report"),
    option("--resume", action="store_true", help="continue the benchmark in DIR: every run's results are kept in "
           "DIR/runs the moment it ends, and this runs only the (run, method) pairs not there yet; a DIR with a "
           "results.parquet and no runs/ is continued from that file (without it, a benchmark refuses a DIR/runs "
           "that holds runs)"),
    option("--force", action="store_true", help="start DIR/runs anew, dropping the runs it holds"),
    option("--jobs", type=positive_int, default=1, metavar="N", help="worker processes (default: 1)"),
    option("--scheduler", metavar="ADDRESS", help="run the runs on the Dask distributed cluster of this scheduler "
           "(e.g. tcp://10.0.0.5:8786) instead of --jobs local processes"),
    QUIET,
)  # fmt: skip
"""The options of ``pmr-ros benchmark``, in the order ``--help`` lists them."""
