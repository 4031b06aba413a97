"""Core results and numpy arrays into the contract's rclpy messages.

Layouts follow ``msg_defs/topics.yaml``: signals are ``sensor_msgs/JointState``
(stamp = sample time, ``name`` = channel names, ``position`` = values), the
verdicts a ``diagnostic_msgs/DiagnosticArray`` with one status per element
(KeyValues spelled by :mod:`pmr_ros.core.results.codec`) and a summary, named
for an aggregator (:mod:`pmr_ros.contract.status_names`), the numeric estimates a
``JointState`` named ``<element>/<quantity>`` (the same codec).  Floats travel as float64
(signals) or shortest round-tripping JSON (KeyValues): both lossless.  The
readers live in :mod:`pmr_ros.contract.layout`, free of ROS imports, so bags
decoded with ``rosbags`` are read by the same code.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from ..contract.layout import CONFLICT, FAILED, STALE
from ..contract.status_names import SUMMARY, status_name
from ..contract.topics import topic
from ..core.results import Diagnosis, ElementDiagnosis
from ..core.results.codec import encode_value, estimate_names_values, status_key_values
from .messages import message_class

__all__ = [
    "LEVEL_NAMES",
    "clock_message",
    "diagnosis_statuses",
    "diagnostic_array",
    "element_level",
    "estimates_message",
    "run_complete_message",
    "signal_message",
    "stamp_from_seconds",
    "text_message",
]

LEVEL_NAMES = {
    DiagnosticStatus.OK: "OK",
    DiagnosticStatus.WARN: "WARN",
    DiagnosticStatus.ERROR: "ERROR",
    DiagnosticStatus.STALE: "STALE",
}


_NO_VERDICT_LEVELS = {STALE: DiagnosticStatus.STALE, CONFLICT: DiagnosticStatus.ERROR, FAILED: DiagnosticStatus.ERROR}
"""Levels of the statuses without numbers (else WARN: insufficient data)."""
_NO_VERDICT_WORDS = {STALE: "stale", CONFLICT: "conflict", FAILED: "diagnosis failed"}


def stamp_from_seconds(seconds: float) -> Time:
    """``builtin_interfaces/Time`` of ``seconds`` (>= 0), nanosecond resolution."""
    nanoseconds = int(round(seconds * 1e9))
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


def signal_message(
    values: Sequence[float] | np.ndarray,
    names: Sequence[str],
    stamp_s: float,
    frame_id: str = "",
    *,
    manual: np.ndarray | None = None,
) -> JointState:
    """A signal sample (r, u or y) as a JointState: stamp = sample time, position = values.

    ``manual`` (u only): which MVs' controllers are off; marked in ``effort``
    (1.0 off, 0.0 on) when any is, else ``effort`` stays empty (msg_defs/topics.yaml).
    """
    msg = JointState()
    msg.header.stamp = stamp_from_seconds(stamp_s)
    msg.header.frame_id = frame_id
    msg.name = list(names)
    msg.position = [float(v) for v in values]
    if manual is not None and np.any(manual):
        msg.effort = [float(bool(m)) for m in manual]
    return msg


def text_message(key: str, text: str) -> Any:
    """A message of contract topic ``key`` whose type is ``std_msgs/String`` (the model topics)."""
    return message_class(topic(key))(data=text)


def run_complete_message(last_stamp_s: float, frame_id: str = "") -> Any:
    """The end of a run (contract topic ``run_complete``): a Header stamped with the last sample's time."""
    msg = message_class(topic("run_complete"))()
    msg.stamp = stamp_from_seconds(last_stamp_s)
    msg.frame_id = frame_id
    return msg


def clock_message(seconds: float) -> Clock:
    """A ``/clock`` message at ``seconds`` of simulated time."""
    return Clock(clock=stamp_from_seconds(seconds))


def element_level(element: ElementDiagnosis) -> bytes:
    """Diagnostic level of a verdict: OK none, WARN one mismatched property (or inconclusive), ERROR two or more.

    An element off in more than one property needs re-identification, one off
    in a single property often only a re-tune, hence the two levels.
    """
    count = len(element.mismatches)
    if count == 0:
        # the data cannot tell: a warning, with the reasons in the message
        return DiagnosticStatus.WARN if element.verdict == "inconclusive" else DiagnosticStatus.OK
    return DiagnosticStatus.WARN if count == 1 else DiagnosticStatus.ERROR


def _key_values(pairs: list[tuple[str, str]]) -> list[KeyValue]:
    return [KeyValue(key=k, value=v) for k, v in pairs]


def diagnosis_statuses(
    diagnosis: Diagnosis, *, prefix: str, hardware_id: str, window: dict[str, Any], state: str | None = None
) -> list[DiagnosticStatus]:
    """One DiagnosticStatus per element of a diagnosis, with or without verdicts, then the summary.

    Parameters
    ----------
    diagnosis : Diagnosis
    prefix : str
        The statuses' common name part (:func:`~pmr_ros.contract.status_names.status_prefix`):
        element G21 is ``<prefix>/G21``, the verdict counts ``<prefix>/summary``.
    hardware_id : str
        The system's name.
    window : dict
        ``window_samples``, ``first_sample``, ``last_sample`` of the diagnosed window.
    state : str, optional
        ``stale`` when the statuses say a signal stopped (level STALE),
        ``conflict`` when two publishers send on one signal topic (ERROR),
        ``failed`` when the window's diagnosis raised (ERROR, the reason naming the exception);
        default: the diagnosis's status (``ok`` or ``insufficient_data``, WARN).
    """
    state = state or diagnosis.status
    statuses = []
    for name, element in diagnosis.elements.items():
        if state == "ok":
            level, message = element_level(element), element.message()
        else:
            level = _NO_VERDICT_LEVELS.get(state, DiagnosticStatus.WARN)
            message = f"{_NO_VERDICT_WORDS.get(state, 'insufficient data')}: {diagnosis.reason}"
        pairs = status_key_values(diagnosis, element, state=state, window=window)
        statuses.append(
            DiagnosticStatus(
                level=level,
                name=status_name(prefix, name),
                message=message,
                hardware_id=hardware_id,
                values=_key_values(pairs),
            )
        )
    return [*statuses, _summary_status(diagnosis, statuses, prefix=prefix, hardware_id=hardware_id, state=state)]


def _summary_status(
    diagnosis: Diagnosis, statuses: list[DiagnosticStatus], *, prefix: str, hardware_id: str, state: str
) -> DiagnosticStatus:
    """The whole matrix in one status: the worst element's level, the verdict counts (or why there are none)."""
    levels = [s.level for s in statuses]
    level = max(levels) if levels else _NO_VERDICT_LEVELS.get(state, DiagnosticStatus.WARN)
    message = diagnosis.verdict_counts() if state == "ok" else (statuses[0].message if statuses else diagnosis.reason)
    return DiagnosticStatus(
        level=level,
        name=status_name(prefix, SUMMARY),
        message=message,
        hardware_id=hardware_id,
        values=_key_values([("status", state), ("elements", encode_value(len(statuses)))]),
    )


def diagnostic_array(statuses: list[DiagnosticStatus], stamp_s: float) -> DiagnosticArray:
    """The ``/diagnostics`` message of ``statuses`` stamped with the window's newest sample time."""
    msg = DiagnosticArray(status=statuses)
    msg.header.stamp = stamp_from_seconds(max(stamp_s, 0.0))
    return msg


def estimates_message(diagnosis: Diagnosis, stamp_s: float, frame_id: str) -> JointState:
    """The numeric estimates of a diagnosis, named ``<element>/<part>.<quantity>`` (NaN where there is none)."""
    names, values = estimate_names_values(diagnosis)
    return signal_message(values, names, stamp_s, frame_id)
