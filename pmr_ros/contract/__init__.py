"""The topic contract and everything that reads it without ROS: rclpy-free, shared by nodes and bags.

``topics`` is ``msg_defs/topics.yaml`` (names, types, QoS); ``layout`` the
messages' contents as plain data; ``samples`` a message's sample index and
checks; ``alignment`` lines r, u, y up by sample stamp; ``windowing`` decides
when and what the diagnostician diagnoses; ``model_topics`` the model topics'
payloads; ``status_names`` the /diagnostics status names; ``failed_window``
the statuses of a window whose diagnosis raised.  The live node
(:mod:`pmr_ros.nodes.pmr_diagnostician`) and the offline replay of a bag
(:mod:`pmr_ros.bag.offline`) both run this code, so they agree.

The names below are imported when first used, so importing one module of
this package does not load the others.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

_WHERE = {
    "ActiveModel": "model_topics",
    "AddResult": "samples",
    "AlignedStretch": "alignment",
    "CONFLICT": "layout",
    "CONTRACT_FILE": "topics",
    "ContractError": "topics",
    "FAILED": "layout",
    "GRID_TOLERANCE": "samples",
    "LEVELS": "layout",
    "NO_VERDICT": "layout",
    "Offer": "windowing",
    "PROGRESS_KEY": "topics",
    "SIGNAL_TOPICS": "topics",
    "STALE": "layout",
    "SampleAligner": "alignment",
    "Topic": "topics",
    "TopicQos": "topics",
    "UsefulData": "windowing",
    "WINDOW_KEYS": "layout",
    "WindowOutcome": "windowing",
    "active_model_text": "model_topics",
    "check_namespace": "topics",
    "check_signal": "samples",
    "check_window_memory": "windowing",
    "decode_value": "layout",
    "diagnosis_from_array": "layout",
    "encode_value": "layout",
    "evaluate_window": "windowing",
    "failed_window": "failed_window",
    "failure_reason": "failed_window",
    "level_name": "layout",
    "load_contract": "topics",
    "msg_defs_dir": "topics",
    "namespaces_of": "topics",
    "offer_signal": "windowing",
    "parse_contract": "topics",
    "read_active_model": "model_topics",
    "read_estimates": "layout",
    "read_signal": "layout",
    "resolve_name": "topics",
    "sample_index": "samples",
    "seconds_from_stamp": "layout",
    "signal_problem": "samples",
    "split_status_name": "status_names",
    "status_name": "status_names",
    "status_prefix": "status_names",
    "status_values": "layout",
    "system_parameters": "model_topics",
    "topic": "topics",
    "useful_data": "windowing",
    "window_dither": "windowing",
    "window_info": "windowing",
    "window_stretches": "windowing",
    "with_system": "model_topics",
    "without_verdict": "windowing",
}
"""Each public name -> the module of this package that defines it."""

__all__ = [
    "ActiveModel",
    "AddResult",
    "AlignedStretch",
    "CONFLICT",
    "CONTRACT_FILE",
    "ContractError",
    "FAILED",
    "GRID_TOLERANCE",
    "LEVELS",
    "NO_VERDICT",
    "Offer",
    "PROGRESS_KEY",
    "SIGNAL_TOPICS",
    "STALE",
    "SampleAligner",
    "Topic",
    "TopicQos",
    "UsefulData",
    "WINDOW_KEYS",
    "WindowOutcome",
    "active_model_text",
    "check_namespace",
    "check_signal",
    "check_window_memory",
    "decode_value",
    "diagnosis_from_array",
    "encode_value",
    "evaluate_window",
    "failed_window",
    "failure_reason",
    "level_name",
    "load_contract",
    "msg_defs_dir",
    "namespaces_of",
    "offer_signal",
    "parse_contract",
    "read_active_model",
    "read_estimates",
    "read_signal",
    "resolve_name",
    "sample_index",
    "seconds_from_stamp",
    "signal_problem",
    "split_status_name",
    "status_name",
    "status_prefix",
    "status_values",
    "system_parameters",
    "topic",
    "useful_data",
    "window_dither",
    "window_info",
    "window_stretches",
    "with_system",
    "without_verdict",
]


__getattr__, __dir__ = lazy_exports(__name__, _WHERE, __all__)


if TYPE_CHECKING:
    from .alignment import AlignedStretch, SampleAligner
    from .failed_window import failed_window, failure_reason
    from .layout import (
        CONFLICT,
        FAILED,
        LEVELS,
        NO_VERDICT,
        STALE,
        WINDOW_KEYS,
        decode_value,
        diagnosis_from_array,
        encode_value,
        level_name,
        read_estimates,
        read_signal,
        seconds_from_stamp,
        status_values,
    )
    from .model_topics import ActiveModel, active_model_text, read_active_model, system_parameters, with_system
    from .samples import GRID_TOLERANCE, AddResult, check_signal, sample_index, signal_problem
    from .status_names import split_status_name, status_name, status_prefix
    from .topics import (
        CONTRACT_FILE,
        PROGRESS_KEY,
        SIGNAL_TOPICS,
        ContractError,
        Topic,
        TopicQos,
        check_namespace,
        load_contract,
        msg_defs_dir,
        namespaces_of,
        parse_contract,
        resolve_name,
        topic,
    )
    from .windowing import (
        Offer,
        UsefulData,
        WindowOutcome,
        check_window_memory,
        evaluate_window,
        offer_signal,
        useful_data,
        window_dither,
        window_info,
        window_stretches,
        without_verdict,
    )
