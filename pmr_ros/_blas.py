"""One BLAS thread for the whole process, unless the user chose otherwise.

The core works on small matrices: the MPC's QP of tens of variables, per-bin
solves of a few regressors.  There OpenBLAS's worker threads only
synchronise, and on shared cores they spin-wait.  Measured at load 6 on this
2-core machine: a 16x16 triangular solve took 13 ms instead of microseconds,
and a saturating Wood-Berry loop ran 128 samples in 27 s instead of 0.6 s.
"""

from __future__ import annotations

import os
import sys

THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
"""Environment variables by which a user chooses the BLAS threads (then left alone)."""


def limit_blas_threads() -> str:
    """Use one BLAS thread in this process and its children; what was done.

    Before numpy is imported, ``OPENBLAS_NUM_THREADS=1`` is set (children
    inherit it: node processes, sweep workers); after, the loaded BLAS is
    limited through threadpoolctl as well.

    Returns
    -------
    str
        ``"user"`` (a variable of :data:`THREAD_VARIABLES` was set: nothing
        changed), ``"environment"`` or ``"runtime"``.
    """
    if any(name in os.environ for name in THREAD_VARIABLES):
        return "user"
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    if "numpy" not in sys.modules:
        return "environment"
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1, user_api="blas")
    return "runtime"
