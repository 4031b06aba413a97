"""The contract's message layouts as plain data, read from any message objects (rclpy or ``rosbags``).

A /diagnostics status carries one element's :meth:`ElementDiagnosis.to_dict`
flattened to dotted KeyValues (``parametric.gain_mismatch_pct``,
``parametric.quality.coherence``, ``model.gain`` ...), each value JSON-encoded
(floats as their shortest round-tripping ``repr``, so lossless; lists and
None as JSON; strings as they are), plus the diagnosis's ``status``
(``ok``, ``insufficient_data`` or ``stale``), ``reason`` and the window
(``window_samples``, ``first_sample``, ``last_sample``) and, when the control
impact was computed, what all the mismatches together do to control
(``impact_all.ise_ratio``, ``impact_all.input_movement_ratio``: the
diagnosis's :attr:`~pmr_ros.core.results.Diagnosis.impact`; each element's own
figures are its ``impact.*``).  The functions here
build those pairs and read them back into the core's :class:`Diagnosis`; they
only read attributes (``header.stamp.sec``, ``status[].values``), so they work
alike on rclpy messages from the wire and ``rosbags`` messages from a bag.
Bags recorded by pmr_ros 0.1 (one flat KeyValue per number) are read too.
No ROS imports.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..config.files import flatten_parameters, nested
from ..core.results import ClassicResult, Diagnosis, ElementDiagnosis, ElementModel, ImpactResult, ParametricResult

__all__ = [
    "LEVELS",
    "NO_VERDICT",
    "CONFLICT",
    "STALE",
    "WINDOW_KEYS",
    "decode_value",
    "diagnosis_from_array",
    "diagnosis_pairs",
    "element_pairs",
    "encode_value",
    "estimate_pairs",
    "level_name",
    "read_estimates",
    "read_signal",
    "seconds_from_stamp",
    "status_values",
]

LEVELS = {0: "OK", 1: "WARN", 2: "ERROR", 3: "STALE"}
"""``diagnostic_msgs/DiagnosticStatus`` level values to their names."""

WINDOW_KEYS = ("window_samples", "first_sample", "last_sample")
"""KeyValues of the diagnosed window [samples]."""

STATUS_KEYS = ("status", "reason", *WINDOW_KEYS)
"""KeyValues of the diagnosis as a whole, beside the element's own."""

STALE = "stale"
"""``status`` of statuses published because a signal stopped."""

CONFLICT = "conflict"
"""``status`` of statuses published because two publishers send on one signal topic (two node sets
without their own namespaces, or a stray publisher): the samples cannot be told apart."""

NO_VERDICT = ("insufficient_data", STALE, CONFLICT)
"""``status`` values of statuses without numbers."""

IMPACT_KEY = "impact_all"
"""Prefix of the KeyValues of the diagnosis-wide control impact (all mismatches together)."""

MESSAGE_KEY = "summary"
"""The element's one-line summary travels as the status message, not as a KeyValue."""


def encode_value(value: Any) -> str:
    """A KeyValue's string: strings as they are, everything else as JSON (floats lossless)."""
    if isinstance(value, str):
        return value
    if isinstance(value, (np.floating, np.integer)):
        value = value.item()
    return json.dumps(value)


def decode_value(text: str) -> Any:
    """Inverse of :func:`encode_value` (a string that is not JSON stays a string)."""
    try:
        return json.loads(text)
    except ValueError:
        return text


def element_pairs(element: ElementDiagnosis) -> dict[str, str]:
    """The KeyValues of one element's diagnosis (without the diagnosis-wide ``STATUS_KEYS``)."""
    flat = flatten_parameters(element.to_dict())
    flat.pop(MESSAGE_KEY, None)
    return {key: encode_value(value) for key, value in flat.items()}


def diagnosis_pairs(diagnosis: Diagnosis) -> dict[str, str]:
    """The diagnosis-wide KeyValues every status carries beside the element's: the impact of all mismatches together.

    Empty when the impact was not computed.
    """
    if diagnosis.impact is None:
        return {}
    flat = flatten_parameters({IMPACT_KEY: diagnosis.to_dict()["impact"]})
    return {key: encode_value(value) for key, value in flat.items()}


def _impact_from(common: Mapping[str, Any]) -> ImpactResult | None:
    values = {key.split(".", 1)[1]: v for key, v in common.items() if key.startswith(f"{IMPACT_KEY}.")}
    if not values:
        return None
    return ImpactResult(float(values["ise_ratio"]), float(values["input_movement_ratio"]), int(values.get("rank", 0)))


def estimate_pairs(element: ElementDiagnosis) -> dict[str, float]:
    """The numbers of an element's results for the estimates topic: ``classic.gain_ratio`` ...

    Every numeric field of the classic part, and of the parametric part when
    the element was diagnosed with the parametric method (``NUMBERS`` of each
    result type), NaN where there is no number, so the names are the same in
    every message of a run; intervals become ``..._interval.low`` / ``.high``.
    """
    out: dict[str, float] = {}
    parts: list[tuple[str, Any]] = [("classic", ClassicResult)]
    if element.method == "parametric":
        parts.append(("parametric", ParametricResult))
    for part, kind in parts:
        result = getattr(element, part)
        for key in kind.NUMBERS:
            value = None if result is None else getattr(result, key)
            if key.endswith("_interval"):
                low, high = value if value is not None else (None, None)
                out[f"{part}.{key}.low"], out[f"{part}.{key}.high"] = _number(low), _number(high)
            else:
                out[f"{part}.{key}"] = _number(value)
    return out


def _number(value: Any) -> float:
    return math.nan if value is None else float(value)


def seconds_from_stamp(stamp: Any) -> float:
    """Seconds of a ``builtin_interfaces/Time``."""
    return stamp.sec + stamp.nanosec * 1e-9


def read_signal(msg: Any) -> tuple[float, tuple[str, ...], np.ndarray]:
    """``(stamp [s], channel names, values)`` of a signal message (JointState), unchecked."""
    return seconds_from_stamp(msg.header.stamp), tuple(msg.name), np.asarray(msg.position, dtype=float)


def level_name(level: Any) -> str:
    """Name of a status level given as rclpy's ``bytes`` or rosbags' ``int``."""
    value = level[0] if isinstance(level, (bytes, bytearray)) else int(level)
    return LEVELS.get(value, repr(level))


def status_values(status: Any) -> dict[str, Any]:
    """A status's KeyValues decoded (numbers, booleans, None, lists, strings)."""
    return {kv.key: decode_value(kv.value) for kv in status.values}


def _legacy_element(
    values: Mapping[str, Any], name: str, models: Mapping[str, tuple[int, int, ElementModel]] | None
) -> ElementDiagnosis:
    """An element of a pmr_ros 0.1 status (flat ``gain_ratio``, ``gain_mismatch_pct_low`` ...)."""
    i, k, model = (models or {}).get(name, (-1, -1, ElementModel("foptd", float("nan"), None, 0)))
    method = "parametric" if values.get("method") == "parametric" else "classic"
    if values.get("verdict") == "insufficient_data":
        return ElementDiagnosis(name, i, k, model, method, reasons=(str(values.get("reason", "")),))
    prefix = "classic." if method == "parametric" else ""
    classic = ClassicResult(
        gain_ratio=float(values[f"{prefix}gain_ratio"]),
        tau_index=float(values[f"{prefix}tau_index"]),
        delay_mismatch_samples=int(values[f"{prefix}delay_mismatch_samples"]),
        # 0.1 statuses of the parametric method carried only the classic numbers, not its flags
        gain_mismatch=bool(values.get("gain_mismatch")) if not prefix else False,
        tau_mismatch=bool(values.get("tau_mismatch")) if not prefix else False,
        delay_mismatch=bool(values.get("delay_mismatch")) if not prefix else False,
    )
    parametric = None
    if method == "parametric":

        def interval(key: str) -> tuple[float, float] | None:
            low, high = values.get(f"{key}_low"), values.get(f"{key}_high")
            return None if low is None or high is None else (float(low), float(high))

        def listed(key: str) -> tuple[str, ...]:
            text = values.get(key)
            return () if not text else tuple(str(text).split(" | "))

        parametric = ParametricResult(
            gain_mismatch_pct=values.get("gain_mismatch_pct"),
            gain_mismatch_pct_interval=interval("gain_mismatch_pct"),
            tau_mismatch_pct=values.get("tau_mismatch_pct"),
            tau_mismatch_pct_interval=interval("tau_mismatch_pct"),
            delay_mismatch_samples=values.get("delay_mismatch_samples"),
            delay_confidence=values.get("delay_confidence"),
            gain_verdict=str(values.get("gain_verdict", "inconclusive")),
            tau_verdict=str(values.get("tau_verdict", "inconclusive")),
            delay_verdict=str(values.get("delay_verdict", "inconclusive")),
            reasons=listed("reasons"),
            warnings=listed("warnings"),
            quality={key[len("quality.") :]: v for key, v in values.items() if key.startswith("quality.")},
        )
    return ElementDiagnosis(name, i, k, model, method, classic=classic, parametric=parametric)


def _legacy_value(text: str) -> Any:
    """A pmr_ros 0.1 KeyValue (``repr``/``str`` of the Python value)."""
    if text in ("True", "False"):
        return text == "True"
    if text == "None":
        return None
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def _status_element(
    status: Any, name: str, models: Mapping[str, tuple[int, int, ElementModel]] | None
) -> tuple[ElementDiagnosis, dict[str, Any]]:
    raw = {kv.key: kv.value for kv in status.values}
    if "element" not in raw:  # a pmr_ros 0.1 status
        values = {key: _legacy_value(text) for key, text in raw.items()}
        status_word = (
            "ok" if values.get("verdict") != "insufficient_data" else str(values.get("status", "insufficient_data"))
        )
        common = {
            "status": status_word,
            "reason": str(values.get("reason", "")),
            **{k: values[k] for k in WINDOW_KEYS if k in values},
        }
        return _legacy_element(values, name, models), common
    values = {key: decode_value(text) for key, text in raw.items()}
    wide = [key for key in values if key in STATUS_KEYS or key.startswith(f"{IMPACT_KEY}.")]
    common = {key: values.pop(key) for key in wide}
    return ElementDiagnosis.from_dict(nested(values)), common


def diagnosis_from_array(
    msg: Any,
    node_name: str | None = None,
    *,
    models: Mapping[str, tuple[int, int, ElementModel]] | None = None,
) -> tuple[Diagnosis, dict[str, Any]]:
    """Rebuild the core :class:`Diagnosis` from a ``/diagnostics`` message.

    Parameters
    ----------
    msg : DiagnosticArray
        rclpy or rosbags message.
    node_name : str, optional
        Only statuses named ``"<node_name>: ..."`` are read.
    models : mapping, optional
        Element name to ``(row, column, ElementModel)``; only needed for the
        statuses of pmr_ros 0.1 bags, which did not carry the model.

    Returns
    -------
    diagnosis : Diagnosis
        ``status`` ok with every element's numbers, or ``insufficient_data``
        (stale data included) with the reason.
    info : dict
        ``levels`` (element -> level name), ``messages``, ``status`` (ok,
        insufficient_data or stale) and the window fields.
    """
    elements, levels, messages = {}, {}, {}
    common: dict[str, Any] = {"status": "ok", "reason": ""}
    for status in msg.status:
        owner, sep, name = status.name.partition(": ")
        if not sep or (node_name is not None and owner != node_name):
            continue
        element, common = _status_element(status, name, models)
        elements[name] = element
        levels[name] = level_name(status.level)
        messages[name] = status.message
    state = str(common.get("status", "ok"))
    method = next((e.method for e in elements.values()), "classic")
    window = {k: common[k] for k in WINDOW_KEYS if k in common}
    samples = int(window.get("window_samples", 0) or 0)
    diagnosis = Diagnosis(
        method,
        "ok" if state == "ok" else "insufficient_data",
        str(common.get("reason", "")),
        samples,
        elements,
        impact=_impact_from(common),
    )
    return diagnosis, {"levels": levels, "messages": messages, "status": state, **window}


def read_estimates(msg: Any) -> dict[str, dict[str, float]]:
    """Element -> quantity -> value of an estimates message."""
    out: dict[str, dict[str, float]] = {}
    for name, value in zip(msg.name, msg.position, strict=False):
        element, _, quantity = name.partition("/")
        out.setdefault(element, {})[quantity] = float(value)
    return out
