"""Messages <-> numpy and core results: the only place that knows message layouts.

Layouts follow ``msg_defs/topics.yaml``: signals are ``sensor_msgs/JointState``
(stamp = sample time, ``name`` = channel names, ``position`` = values), the
verdicts a ``diagnostic_msgs/DiagnosticArray`` with one status per element,
the numeric estimates a ``JointState`` named ``<element>/<quantity>``.
Floats travel as float64 (signals) or ``repr`` strings (KeyValue): both lossless.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from ..core.pmr import Diagnosis, ElementDiagnosis

ESTIMATE_QUANTITIES = ("gain_ratio", "tau_index", "delay_mismatch_samples")
"""Quantities of each element on the estimates topic, in this order."""

LEVEL_NAMES = {DiagnosticStatus.OK: "OK", DiagnosticStatus.WARN: "WARN", DiagnosticStatus.ERROR: "ERROR", DiagnosticStatus.STALE: "STALE"}

_BOOL_KEYS = ("gain_mismatch", "tau_mismatch", "delay_mismatch")
_FLOAT_KEYS = ("gain_ratio", "tau_index")
_INT_KEYS = ("delay_mismatch_samples",)


def stamp_from_seconds(seconds: float) -> Time:
    """``builtin_interfaces/Time`` of ``seconds`` (>= 0), nanosecond resolution."""
    nanoseconds = int(round(seconds * 1e9))
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


def seconds_from_stamp(stamp: Time) -> float:
    """Seconds of a ``builtin_interfaces/Time``."""
    return stamp.sec + stamp.nanosec * 1e-9


def signal_message(values: Sequence[float], names: Sequence[str], stamp_s: float, frame_id: str = "") -> JointState:
    """A signal sample (r, u or y) as a JointState: stamp = sample time, position = values."""
    msg = JointState()
    msg.header.stamp = stamp_from_seconds(stamp_s)
    msg.header.frame_id = frame_id
    msg.name = list(names)
    msg.position = [float(v) for v in values]
    return msg


def read_signal(msg: JointState) -> tuple[float, tuple[str, ...], np.ndarray]:
    """``(stamp [s], channel names, values)`` of a signal message, unchecked."""
    return seconds_from_stamp(msg.header.stamp), tuple(msg.name), np.asarray(msg.position, dtype=float)


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
        return DiagnosticStatus.OK
    return DiagnosticStatus.WARN if count == 1 else DiagnosticStatus.ERROR


def _values(pairs: dict) -> list[KeyValue]:
    return [KeyValue(key=k, value=repr(v) if isinstance(v, float) else str(v)) for k, v in pairs.items()]


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


def _parse(value: str):
    if value in ("True", "False"):
        return value == "True"
    if value == "None":
        return None
    try:
        return int(value)
    except ValueError:
        pass
    try:
        return float(value)
    except ValueError:
        return value


def status_values(status: DiagnosticStatus) -> dict:
    """A status's KeyValues as Python values (numbers, booleans, None, strings)."""
    return {kv.key: _parse(kv.value) for kv in status.values}


def diagnosis_from_array(msg: DiagnosticArray, node_name: str | None = None) -> tuple[Diagnosis, dict]:
    """Rebuild the core :class:`Diagnosis` from a ``/diagnostics`` message.

    Parameters
    ----------
    msg : DiagnosticArray
    node_name : str, optional
        Only statuses named ``"<node_name>: ..."`` are read.

    Returns
    -------
    diagnosis : Diagnosis
        ``status`` ok with every element's numbers, or ``insufficient_data``
        (``stale`` data included) with the reason.
    info : dict
        ``levels`` (element -> level name), ``messages`` and the window fields.
    """
    elements, levels, messages = {}, {}, {}
    reason, state, window = "", "ok", {}
    for status in msg.status:
        owner, sep, element = status.name.partition(": ")
        if not sep or (node_name is not None and owner != node_name):
            continue
        values = status_values(status)
        levels[element] = LEVEL_NAMES.get(status.level, repr(status.level))
        messages[element] = status.message
        window = {k: values[k] for k in ("window_samples", "first_sample", "last_sample") if k in values}
        if values.get("verdict") == "insufficient_data":
            state, reason = "insufficient_data", str(values.get("reason", status.message))
            elements[element] = ElementDiagnosis(element)
            continue
        kwargs = {k: values.get(k) for k in _FLOAT_KEYS + _BOOL_KEYS + _INT_KEYS}
        elements[element] = ElementDiagnosis(element, **kwargs)
    if state != "ok":
        elements = {name: ElementDiagnosis(name) for name in elements}
    samples = int(window.get("window_samples", 0) or 0)
    return Diagnosis(elements, state, reason, samples), {"levels": levels, "messages": messages, **window}


def estimates_message(diagnosis: Diagnosis, stamp_s: float, frame_id: str) -> JointState:
    """The numeric estimates of a diagnosis with verdicts, named ``<element>/<quantity>``."""
    names, values = [], []
    for name, element in diagnosis.elements.items():
        for quantity in ESTIMATE_QUANTITIES:
            value = getattr(element, quantity)
            names.append(f"{name}/{quantity}")
            values.append(math.nan if value is None else float(value))
    return signal_message(values, names, stamp_s, frame_id)


def read_estimates(msg: JointState) -> dict[str, dict[str, float]]:
    """Element -> quantity -> value of an estimates message."""
    out: dict[str, dict[str, float]] = {}
    for name, value in zip(msg.name, msg.position, strict=False):
        element, _, quantity = name.partition("/")
        out.setdefault(element, {})[quantity] = float(value)
    return out
