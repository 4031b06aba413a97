"""Messages <-> numpy and core results: the only place that knows message layouts.

Layouts follow ``msg_defs/topics.yaml``: signals are ``sensor_msgs/JointState``
(stamp = sample time, ``name`` = channel names, ``position`` = values), the
verdicts a ``diagnostic_msgs/DiagnosticArray`` with one status per element,
the numeric estimates a ``JointState`` named ``<element>/<quantity>``.
Floats travel as float64 (signals) or ``repr`` strings (KeyValue): both lossless.
The readers (``read_signal``, ``diagnosis_from_array``, ...) live in
:mod:`pmr_ros.ros.layout`, free of ROS imports, so bags decoded with ``rosbags``
are read by the same code; they are re-exported here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from ..core.pmr import Diagnosis, ElementDiagnosis
from .layout import BOOL_KEYS as _BOOL_KEYS
from .layout import FLOAT_KEYS as _FLOAT_KEYS
from .layout import INT_KEYS as _INT_KEYS
from .layout import (
    PARAMETRIC_FLOAT_KEYS,
    diagnosis_from_array,
    parametric_pairs,
    read_estimates,
    read_signal,
    seconds_from_stamp,
    status_values,
)

__all__ = [
    "ESTIMATE_QUANTITIES", "LEVEL_NAMES", "clock_message", "diagnosis_from_array", "diagnostic_array", "element_level", "estimates_message",
    "no_verdict_statuses", "read_estimates", "read_signal", "seconds_from_stamp", "signal_message", "stamp_from_seconds", "status_values", "verdict_statuses",
]

ESTIMATE_QUANTITIES = ("gain_ratio", "tau_index", "delay_mismatch_samples")
"""Quantities of each element on the estimates topic, in this order."""

LEVEL_NAMES = {DiagnosticStatus.OK: "OK", DiagnosticStatus.WARN: "WARN", DiagnosticStatus.ERROR: "ERROR", DiagnosticStatus.STALE: "STALE"}


def stamp_from_seconds(seconds: float) -> Time:
    """``builtin_interfaces/Time`` of ``seconds`` (>= 0), nanosecond resolution."""
    nanoseconds = int(round(seconds * 1e9))
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


def signal_message(values: Sequence[float], names: Sequence[str], stamp_s: float, frame_id: str = "") -> JointState:
    """A signal sample (r, u or y) as a JointState: stamp = sample time, position = values."""
    msg = JointState()
    msg.header.stamp = stamp_from_seconds(stamp_s)
    msg.header.frame_id = frame_id
    msg.name = list(names)
    msg.position = [float(v) for v in values]
    return msg


def clock_message(seconds: float) -> Clock:
    """A ``/clock`` message at ``seconds`` of simulated time."""
    return Clock(clock=stamp_from_seconds(seconds))


def element_level(element: ElementDiagnosis) -> bytes:
    """Diagnostic level of a verdict: OK none, WARN one mismatched property, ERROR two or more.

    An element off in more than one property needs re-identification, one off
    in a single property often only a re-tune, hence the two levels.
    """
    count = sum(bool(flag) for flag in (element.gain_mismatch, element.tau_mismatch, element.delay_mismatch))
    if count == 0:
        # the data cannot tell: a warning, with the reasons in the message
        return DiagnosticStatus.WARN if element.verdict == "inconclusive" else DiagnosticStatus.OK
    return DiagnosticStatus.WARN if count == 1 else DiagnosticStatus.ERROR


def _values(pairs: dict) -> list[KeyValue]:
    # repr of a Python float round-trips exactly; numpy scalars print their type, so convert first
    return [KeyValue(key=k, value=repr(float(v)) if isinstance(v, float) else str(v)) for k, v in pairs.items()]


def verdict_statuses(diagnosis: Diagnosis, node_name: str, hardware_id: str, window: dict) -> list[DiagnosticStatus]:
    """One DiagnosticStatus per element of a diagnosis with verdicts.

    Parameters
    ----------
    diagnosis : Diagnosis
        With ``status == "ok"``.
    node_name : str
        Prefix of each status name (``pmr_diagnostician: G21``).
    hardware_id : str
        The system's name.
    window : dict
        ``window_samples``, ``first_sample``, ``last_sample`` of the diagnosed window.
    """
    statuses = []
    for name, element in diagnosis.elements.items():
        pairs = {"verdict": element.verdict}
        for key in _FLOAT_KEYS + _BOOL_KEYS + _INT_KEYS:
            pairs[key] = getattr(element, key)
        pairs.update(gain_direction=element.gain_direction, tau_direction=element.tau_direction)
        pairs.update(parametric_pairs(element))
        pairs.update(window)
        statuses.append(DiagnosticStatus(level=element_level(element), name=f"{node_name}: {name}", message=element.summary(), hardware_id=hardware_id, values=_values(pairs)))
    return statuses


def no_verdict_statuses(element_names: Sequence[str], level: bytes, reason: str, node_name: str, hardware_id: str, window: dict) -> list[DiagnosticStatus]:
    """Statuses without numbers, for insufficient (WARN) or stale (STALE) data, with the reason.

    The message is ``insufficient data: <reason>`` or ``stale: <reason>``; the
    ``reason`` KeyValue holds the reason alone.
    """
    status = "stale" if level == DiagnosticStatus.STALE else "insufficient_data"
    message = f"{'stale' if status == 'stale' else 'insufficient data'}: {reason}"
    pairs = {"verdict": "insufficient_data", "status": status, "reason": reason, **window}
    return [DiagnosticStatus(level=level, name=f"{node_name}: {name}", message=message, hardware_id=hardware_id, values=_values(pairs)) for name in element_names]


def diagnostic_array(statuses: list[DiagnosticStatus], stamp_s: float) -> DiagnosticArray:
    """The ``/diagnostics`` message of ``statuses`` stamped with the window's newest sample time."""
    msg = DiagnosticArray(status=statuses)
    msg.header.stamp = stamp_from_seconds(max(stamp_s, 0.0))
    return msg


def estimates_message(diagnosis: Diagnosis, stamp_s: float, frame_id: str) -> JointState:
    """The numeric estimates of a diagnosis with verdicts, named ``<element>/<quantity>``."""
    names, values = [], []
    for name, element in diagnosis.elements.items():
        quantities = {quantity: getattr(element, quantity) for quantity in ESTIMATE_QUANTITIES}
        pairs = parametric_pairs(element)
        quantities.update({quantity: pairs[quantity] for quantity in PARAMETRIC_FLOAT_KEYS if pairs})
        for quantity, value in quantities.items():
            names.append(f"{name}/{quantity}")
            values.append(math.nan if value is None else float(value))
    return signal_message(values, names, stamp_s, frame_id)
