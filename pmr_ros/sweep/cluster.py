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

import asyncio
from collections.abc import Callable, Sequence
from typing import Any

from ..config import PmrConfig

CONNECT_TIMEOUT_S = 5.0
"""How long to wait for the scheduler to answer [s] (``pmr-ros sweep --connect-timeout``)."""


class ClusterError(RuntimeError):
    """The cluster cannot be used: distributed missing, or the scheduler unreachable."""


def _distributed() -> None:
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise ClusterError(
            "--scheduler needs the Dask distributed package: pip install 'pmr_ros[cluster]' (or distributed)"
        ) from None


async def _identity(address: str, timeout_s: float) -> Any:
    """The answer of whatever listens at ``address`` to Dask's ``identity`` request, each step bounded."""
    from distributed.comm import connect

    comm = await asyncio.wait_for(connect(address, timeout=timeout_s), timeout_s)
    try:
        await asyncio.wait_for(comm.write({"op": "identity"}), timeout_s)
        return await asyncio.wait_for(comm.read(), timeout_s)
    finally:
        comm.abort()


def check_scheduler(address: str, *, timeout_s: float | None = None) -> None:
    """Refuse in one line an address where no Dask scheduler answers within ``timeout_s`` seconds.

    distributed's ``Client`` waits without end for a server that accepts the
    connection but never speaks Dask (an HTTP server), and a failed ``Client``
    prints a traceback when it is collected.  So the address is asked first,
    with every step bounded, in a loop of its own that is gone afterwards.

    Parameters
    ----------
    address : str
        The scheduler, e.g. ``tcp://10.0.0.5:8786``.
    timeout_s : float, optional
        Bound of each step (connect, ask, answer) [s]; default :data:`CONNECT_TIMEOUT_S`.

    Raises
    ------
    ClusterError
        distributed missing, a malformed address, nothing answering, or an answer that is not a scheduler's.
    """
    _distributed()
    timeout_s = CONNECT_TIMEOUT_S if timeout_s is None else timeout_s
    prefix = f"--scheduler {address}: "
    try:
        reply = asyncio.run(_identity(address, timeout_s))
    except ValueError as exc:
        raise ClusterError(f"{prefix}not a Dask address ({exc}); e.g. tcp://10.0.0.5:8786") from None
    except (OSError, asyncio.TimeoutError) as exc:
        why = " ".join(str(exc).split()) or f"no Dask answer within {timeout_s:g} s"
        raise ClusterError(f"{prefix}cannot connect to a Dask scheduler there: {why}") from None
    except Exception as exc:  # whatever the other end sent broke the protocol: it is no scheduler
        raise ClusterError(f"{prefix}not a Dask scheduler ({type(exc).__name__}: {exc})") from None
    if not isinstance(reply, dict) or reply.get("type") != "Scheduler":
        raise ClusterError(f"{prefix}answers, but is not a Dask scheduler ({str(reply)[:80]})")


def _client(address: str) -> Any:
    _distributed()
    from distributed import Client

    try:
        return Client(address, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise ClusterError(f"--scheduler {address}: cannot connect to a Dask scheduler there: {exc}") from None


def run_on_cluster(
    config: PmrConfig | Any,
    tasks: Sequence[Any],
    address: str,
    *,
    work: Callable[[Any, Any], tuple[Any, Any, float]],
    record: Callable[[Any, Any, float], None],
) -> None:
    """Run ``work(config, task)`` for each task on the Dask cluster at ``address``; ``record`` each result at once.

    Parameters
    ----------
    config : PmrConfig or any
        The sweep's configuration, or whatever every task shares (the monitor's record): scattered to every
        worker once.
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
