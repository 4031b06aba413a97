"""rosbag2 bags of pmr_ros runs (``rosbags``, no rclpy): writing, reading, repair, the offline replay.

``writer`` records the contract's topics and the run's configuration, ``reader``
reads a bag (also one whose recorder was killed), ``storage`` the storage
formats and their errors, ``repair`` copies a killed recording into a complete
bag, ``offline`` feeds a bag's r, u, y through the live diagnostician's aligner
and windows (the whole flow with the comparison: :mod:`pmr_ros.service.bag_diagnosis`).

The names below are imported when first used, so importing one module of
this package does not load the others.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

_WHERE = {
    "Bag": "reader",
    "BagError": "storage",
    "BagMessage": "reader",
    "BagWriter": "writer",
    "DropCounts": "offline",
    "OfflineResult": "offline",
    "RecordedVerdict": "offline",
    "RunConfig": "storage",
    "bag_configuration": "offline",
    "bag_namespace": "offline",
    "check_system": "offline",
    "held_samples": "offline",
    "looks_like_bag": "writer",
    "open_bag": "reader",
    "prepare_output": "writer",
    "recorded_topics": "storage",
    "recorded_verdicts": "offline",
    "reindex": "repair",
    "replay_bag": "offline",
    "required_topics": "offline",
    "rosbags_qos": "storage",
    "typestore": "storage",
}
"""Each public name -> the module of this package that defines it."""

__all__ = [
    "Bag",
    "BagError",
    "BagMessage",
    "BagWriter",
    "DropCounts",
    "OfflineResult",
    "RecordedVerdict",
    "RunConfig",
    "bag_configuration",
    "bag_namespace",
    "check_system",
    "held_samples",
    "looks_like_bag",
    "open_bag",
    "prepare_output",
    "recorded_topics",
    "recorded_verdicts",
    "reindex",
    "replay_bag",
    "required_topics",
    "rosbags_qos",
    "typestore",
]


__getattr__, __dir__ = lazy_exports(__name__, _WHERE, __all__)


if TYPE_CHECKING:
    from .offline import (
        DropCounts,
        OfflineResult,
        RecordedVerdict,
        bag_configuration,
        bag_namespace,
        check_system,
        held_samples,
        recorded_verdicts,
        replay_bag,
        required_topics,
    )
    from .reader import Bag, BagMessage, open_bag
    from .repair import reindex
    from .storage import BagError, RunConfig, recorded_topics, rosbags_qos, typestore
    from .writer import BagWriter, looks_like_bag, prepare_output
