"""Reading the contract's message layouts from any message objects, rclpy or ``rosbags``.

The functions here only read attributes (``header.stamp.sec``, ``status[].values``,
...), so they work alike on rclpy messages from the wire and on ``rosbags``
messages from a bag: the live diagnostician's listeners and the offline
diagnosis of a bag decode verdicts with the same code.  No ROS imports.
:mod:`pmr_ros.ros.convert` re-exports them beside the message builders.
"""

from __future__ import annotations

import numpy as np

from ..core.parametric import ElementEstimate
from ..core.pmr import Diagnosis, ElementDiagnosis

LEVELS = {0: "OK", 1: "WARN", 2: "ERROR", 3: "STALE"}
"""``diagnostic_msgs/DiagnosticStatus`` level values to their names."""

BOOL_KEYS = ("gain_mismatch", "tau_mismatch", "delay_mismatch")
FLOAT_KEYS = ("gain_ratio", "tau_index")
INT_KEYS = ("delay_mismatch_samples",)
WINDOW_KEYS = ("window_samples", "first_sample", "last_sample")
PARAMETRIC_FLOAT_KEYS = (
    "gain_mismatch_pct", "gain_mismatch_pct_low", "gain_mismatch_pct_high",
    "tau_mismatch_pct", "tau_mismatch_pct_low", "tau_mismatch_pct_high", "delay_confidence",
)
"""Numeric KeyValues of the parametric method (also on /pmr/estimates); ``*_low``/``*_high`` bound the interval."""
QUALITY_PREFIX = "quality."
CLASSIC_PREFIX = "classic."
LIST_SEPARATOR = " | "
"""Joins the reasons (and warnings) in one KeyValue."""


def parametric_pairs(element: ElementDiagnosis) -> dict:
    """The KeyValues that carry an element's parametric estimate (empty for classic)."""
    p = element.parametric
    if p is None:
        return {}
    pairs = {"method": "parametric", "gain_mismatch_pct": p.gain_mismatch_pct, "tau_mismatch_pct": p.tau_mismatch_pct, "delay_confidence": p.delay_confidence}
    for key, interval in (("gain_mismatch_pct", p.gain_mismatch_pct_interval), ("tau_mismatch_pct", p.tau_mismatch_pct_interval)):
        pairs[f"{key}_low"], pairs[f"{key}_high"] = interval if interval is not None else (None, None)
    pairs.update(gain_verdict=p.gain_verdict, tau_verdict=p.tau_verdict, delay_verdict=p.delay_verdict)
    pairs["reasons"] = LIST_SEPARATOR.join(p.reasons)
    pairs["warnings"] = LIST_SEPARATOR.join(p.warnings)
    pairs.update({QUALITY_PREFIX + k: v for k, v in p.quality.items()})
    pairs.update({CLASSIC_PREFIX + k: v for k, v in (element.classic or {}).items()})
    return pairs


def _parametric_from(values: dict, name: str, delay: int | None) -> ElementEstimate:
    def interval(key):
        low, high = values.get(f"{key}_low"), values.get(f"{key}_high")
        return None if low is None or high is None else (float(low), float(high))

    def listed(key):
        text = values.get(key)
        return [] if not text else str(text).split(LIST_SEPARATOR)

    return ElementEstimate(
        element=name,
        gain_mismatch_pct=values.get("gain_mismatch_pct"),
        gain_mismatch_pct_interval=interval("gain_mismatch_pct"),
        tau_mismatch_pct=values.get("tau_mismatch_pct"),
        tau_mismatch_pct_interval=interval("tau_mismatch_pct"),
        delay_mismatch_samples=delay,
        delay_confidence=values.get("delay_confidence"),
        gain_verdict=str(values.get("gain_verdict", "inconclusive")),
        tau_verdict=str(values.get("tau_verdict", "inconclusive")),
        delay_verdict=str(values.get("delay_verdict", "inconclusive")),
        reasons=listed("reasons"),
        warnings=listed("warnings"),
        quality={k[len(QUALITY_PREFIX):]: v for k, v in values.items() if k.startswith(QUALITY_PREFIX)},
    )


def seconds_from_stamp(stamp) -> float:
    """Seconds of a ``builtin_interfaces/Time``."""
    return stamp.sec + stamp.nanosec * 1e-9


def read_signal(msg) -> tuple[float, tuple[str, ...], np.ndarray]:
    """``(stamp [s], channel names, values)`` of a signal message (JointState), unchecked."""
    return seconds_from_stamp(msg.header.stamp), tuple(msg.name), np.asarray(msg.position, dtype=float)


def level_name(level) -> str:
    """Name of a status level given as rclpy's ``bytes`` or rosbags' ``int``."""
    value = level[0] if isinstance(level, (bytes, bytearray)) else int(level)
    return LEVELS.get(value, repr(level))


def parse_value(value: str):
    """A KeyValue's string back to the Python value it was written from (``repr``/``str``)."""
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


def status_values(status) -> dict:
    """A status's KeyValues as Python values (numbers, booleans, None, strings)."""
    return {kv.key: parse_value(kv.value) for kv in status.values}


def diagnosis_from_array(msg, node_name: str | None = None) -> tuple[Diagnosis, dict]:
    """Rebuild the core :class:`Diagnosis` from a ``/diagnostics`` message.

    Parameters
    ----------
    msg : DiagnosticArray
        rclpy or rosbags message.
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
    reason, state, window, method = "", "ok", {}, "classic"
    for status in msg.status:
        owner, sep, element = status.name.partition(": ")
        if not sep or (node_name is not None and owner != node_name):
            continue
        values = status_values(status)
        levels[element] = level_name(status.level)
        messages[element] = status.message
        window = {k: values[k] for k in WINDOW_KEYS if k in values}
        if values.get("verdict") == "insufficient_data":
            state, reason = "insufficient_data", str(values.get("reason", status.message))
            elements[element] = ElementDiagnosis(element)
            continue
        kwargs = {k: values.get(k) for k in FLOAT_KEYS + BOOL_KEYS + INT_KEYS}
        elements[element] = ElementDiagnosis(element, **kwargs)
        if values.get("method") == "parametric":
            method = "parametric"
            estimate = _parametric_from(values, element, kwargs["delay_mismatch_samples"])
            elements[element].parametric = estimate
            elements[element].reasons = list(estimate.reasons)
            classic = {k[len(CLASSIC_PREFIX):]: v for k, v in values.items() if k.startswith(CLASSIC_PREFIX)}
            elements[element].classic = classic or None
    if state != "ok":
        elements = {name: ElementDiagnosis(name) for name in elements}
    samples = int(window.get("window_samples", 0) or 0)
    return Diagnosis(elements, state, reason, samples, method=method), {"levels": levels, "messages": messages, **window}


def read_estimates(msg) -> dict[str, dict[str, float]]:
    """Element -> quantity -> value of an estimates message."""
    out: dict[str, dict[str, float]] = {}
    for name, value in zip(msg.name, msg.position, strict=False):
        element, _, quantity = name.partition("/")
        out.setdefault(element, {})[quantity] = float(value)
    return out
