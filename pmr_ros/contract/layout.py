"""The contract's message layouts as plain data, read from any message objects (rclpy or ``rosbags``).

A /diagnostics status carries one element's fields as KeyValues spelled by
the result codec (:func:`pmr_ros.core.results.codec.status_key_values`:
``parametric.gain_mismatch_pct``, ``parametric.gain_mismatch_pct_low``,
``model.gain`` ..., plus ``status`` (``ok``, ``insufficient_data``,
``stale`` or ``conflict``), ``reason``, the window and ``impact_all.*``); the
estimates topic names ``<element>/<path>`` of the same spelling.  The
functions here only read attributes (``header.stamp.sec``,
``status[].values``) and hand the pairs to the codec, so they work alike on
rclpy messages from the wire and ``rosbags`` messages from a bag (those
recorded by pmr_ros 0.1 too).  No ROS imports.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ..core.results import Diagnosis, ElementModel
from ..core.results.codec import (
    WINDOW_KEYS,
    decode_value,
    diagnosis_from_key_values,
    encode_value,
    estimates_from_names_values,
)

__all__ = [
    "CONFLICT",
    "LEVELS",
    "NO_VERDICT",
    "STALE",
    "WINDOW_KEYS",
    "decode_value",
    "diagnosis_from_array",
    "encode_value",
    "level_name",
    "read_estimates",
    "read_signal",
    "seconds_from_stamp",
    "status_values",
]

LEVELS = {0: "OK", 1: "WARN", 2: "ERROR", 3: "STALE"}
"""``diagnostic_msgs/DiagnosticStatus`` level values to their names."""

STALE = "stale"
"""``status`` of statuses published because a signal stopped."""

CONFLICT = "conflict"
"""``status`` of statuses published because two publishers send on one signal topic (two node sets
without their own namespaces, or a stray publisher): the samples cannot be told apart."""

NO_VERDICT = ("insufficient_data", STALE, CONFLICT)
"""``status`` values of statuses without numbers."""


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
    statuses, levels, messages = {}, {}, {}
    for status in msg.status:
        owner, sep, name = status.name.partition(": ")
        if not sep or (node_name is not None and owner != node_name):
            continue
        statuses[name] = [(kv.key, kv.value) for kv in status.values]
        levels[name] = level_name(status.level)
        messages[name] = status.message
    diagnosis, common = diagnosis_from_key_values(statuses, models=models)
    common.pop("reason")
    return diagnosis, {"levels": levels, "messages": messages, **common}


def read_estimates(msg: Any) -> dict[str, dict[str, float]]:
    """Element -> quantity (``classic.gain_ratio`` ...) -> value of an estimates message."""
    return estimates_from_names_values(list(msg.name), list(msg.position))
