"""A window whose diagnosis raised: statuses without a verdict that name the failure in one line.

When the live diagnostician's job for a window raises (a numerical corner of
the core, a bug), saying nothing would leave the previous window's verdicts on
/diagnostics as if they were current, and a run waiting for its final verdicts
would wait for its watch's timeout.  So the window gets what a window without
enough data gets, every element inconclusive and no numbers, but with
``status: failed`` (level ERROR, as a conflict) and the message
``diagnosis failed: <exception type>: <message>``.  The offline diagnosis of a
bag has no such window: there the exception ends the command.
"""

from __future__ import annotations

from ..config import PmrConfig
from .alignment import SampleAligner
from .layout import FAILED
from .windowing import WindowOutcome, without_verdict

__all__ = ["failed_window", "failure_reason"]


def failure_reason(exc: BaseException) -> str:
    """``<exception type>: <message>`` on one line (a message over several lines joined, an empty one left out).

    Parameters
    ----------
    exc : BaseException
        What the diagnosis raised.

    Returns
    -------
    str
        E.g. ``ValueError: f(a) and f(b) must have different signs``.
    """
    message = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {message}" if message else type(exc).__name__


def failed_window(aligner: SampleAligner, config: PmrConfig, exc: BaseException, *, since: int = 0) -> WindowOutcome:
    """The outcome of the window of ``aligner`` whose diagnosis raised ``exc``: no verdict, kind ``failed``.

    Parameters
    ----------
    aligner : SampleAligner
        The snapshot the failed diagnosis was given (its window and newest sample name the statuses).
    config : PmrConfig
        The configuration the diagnosis ran with (the elements, the method, the window's length).
    exc : BaseException
        What the diagnosis raised.
    since : int
        The first sample the controller ran on ``config.model`` (see
        :func:`~pmr_ros.contract.windowing.evaluate_window`).

    Returns
    -------
    WindowOutcome
        Kind ``failed``, its reason :func:`failure_reason` of ``exc``.
    """
    return without_verdict(FAILED, failure_reason(exc), aligner, config, since=since)
