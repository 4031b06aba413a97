"""Run a sweep's points on a Dask distributed cluster (``pmr-ros sweep --scheduler ADDRESS``).

The configuration is sent to every worker once; each point is one task, the
function the caller gives (``pmr_ros.sweep.execute`` gives ``timed_point``,
what its local process pool runs), so a cluster writes the same rows as the local pool
(in the order the points finish, as the pool does).  The workers need
pmr_ros installed (the same version) and are started by whoever runs the
cluster (``dask scheduler``, ``dask worker ADDRESS``).  Needs the optional
``distributed`` package (``pip install 'pmr_ros[cluster]'``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from ..config import PmrConfig

CONNECT_TIMEOUT_S = 30.0
"""How long to wait for the scheduler to answer [s]."""


class ClusterError(RuntimeError):
    """The cluster cannot be used: distributed missing, or the scheduler unreachable."""


def _client(address: str) -> Any:
    try:
        from distributed import Client
    except ImportError:
        raise ClusterError(
            "--scheduler needs the Dask distributed package: pip install 'pmr_ros[cluster]' (or distributed)"
        ) from None
    try:
        return Client(address, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise ClusterError(f"--scheduler {address}: cannot connect to a Dask scheduler there: {exc}") from None


def run_on_cluster(
    config: PmrConfig,
    tasks: Sequence[Any],
    address: str,
    *,
    work: Callable[[PmrConfig, Any], tuple[Any, list[dict], float]],
    record: Callable[[Any, list[dict], float], None],
) -> None:
    """Run ``work(config, task)`` for each task on the Dask cluster at ``address``; ``record`` each result at once.

    Parameters
    ----------
    config : PmrConfig
        The sweep's configuration (scattered to every worker once).
    tasks : sequence
        The points to run (``PointTask``), in the order to submit them.
    address : str
        The scheduler, e.g. ``tcp://10.0.0.5:8786``.
    work : callable
        Run on a worker: ``(task, rows, cpu_s)`` of one point; importable by the workers.
    record : callable
        Called with ``(task, rows, cpu_s)`` as each point finishes.

    Raises
    ------
    ClusterError
        If distributed is not installed or the scheduler cannot be reached.
    """
    from distributed import as_completed

    client = _client(address)
    futures = []
    try:
        shared = client.scatter(config, broadcast=True)
        futures = [client.submit(work, shared, task, pure=False) for task in tasks]
        for _, (task, rows, cpu_s) in as_completed(futures, with_results=True, loop=client.loop):
            record(task, rows, cpu_s)
    finally:
        client.cancel([f for f in futures if not f.done()])
        client.close()
