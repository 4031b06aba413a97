"""The contract's message layouts as plain data, read from any message objects (rclpy or ``rosbags``).

A /diagnostics status carries one element's fields as KeyValues spelled by
the result codec (:func:`pmr_ros.core.results.codec.status_key_values`:
``parametric.gain_mismatch_pct``, ``parametric.gain_mismatch_pct_low``,
``model.gain`` ..., plus ``status`` (``ok``, ``insufficient_data``,
``stale``, ``conflict`` or ``failed``), ``reason``, the window and ``impact_all.*``); the
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
from .status_names import ROOT, SUMMARY, split_status_name

__all__ = [
    "CONFLICT",
    "FAILED",
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

FAILED = "failed"
"""``status`` of statuses published because the window's diagnosis raised: the reason names the exception."""

NO_VERDICT = ("insufficient_data", STALE, CONFLICT, FAILED)
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
    prefix: str | None = None,
    models: Mapping[str, tuple[int, int, ElementModel]] | None = None,
) -> tuple[Diagnosis, dict[str, Any]]:
    """Rebuild the core :class:`Diagnosis` from a ``/diagnostics`` message.

    Statuses named either way are read (:mod:`pmr_ros.contract.status_names`):
    ``pmr/<namespace>/<system>/<element>`` and, in older bags,
    ``<node name>: <element>``; the ``.../summary`` status and other nodes'
    statuses are passed over.

    Parameters
    ----------
    msg : DiagnosticArray
        rclpy or rosbags message (one publisher's).
    node_name : str, optional
        Only statuses named ``"<node_name>: ..."`` are read of the older spelling.
    prefix : str, optional
        Only statuses named ``"<prefix>/..."`` are read of the path-like spelling
        (:func:`~pmr_ros.contract.status_names.status_prefix`).
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
        insufficient_data, stale, conflict or failed) and the window fields.
    """
    statuses, levels, messages = {}, {}, {}
    for status in msg.status:
        name = _element_of(status.name, node_name, prefix)
        if name is None:
            continue
        statuses[name] = [(kv.key, kv.value) for kv in status.values]
        levels[name] = level_name(status.level)
        messages[name] = status.message
    diagnosis, common = diagnosis_from_key_values(statuses, models=models)
    common.pop("reason")
    return diagnosis, {"levels": levels, "messages": messages, **common}


def _element_of(name: str, node_name: str | None, prefix: str | None) -> str | None:
    """The element a status of the diagnostician is about, or None (another node's, the summary, filtered out)."""
    split = split_status_name(name)
    if split is None:
        return None
    owner, last = split
    if owner.startswith(f"{ROOT}/"):
        return None if last == SUMMARY or prefix not in (None, owner) else last
    return None if node_name not in (None, owner) else last


def read_estimates(msg: Any) -> dict[str, dict[str, float]]:
    """Element -> quantity (``classic.gain_ratio`` ...) -> value of an estimates message."""
    return estimates_from_names_values(list(msg.name), list(msg.position))
