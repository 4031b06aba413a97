"""The contract's topics in rclpy terms: message classes and QoS profiles."""

from __future__ import annotations

import importlib
from typing import Any

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from ..contract.topics import Topic, TopicQos

__all__ = ["message_class", "qos_profile"]


def qos_profile(qos: TopicQos) -> QoSProfile:
    """The rclpy ``QoSProfile`` of a contract QoS (policy names from :meth:`TopicQos.policies`)."""
    names = qos.policies()
    return QoSProfile(
        history=getattr(HistoryPolicy, names["history"]),
        depth=qos.depth,
        reliability=getattr(ReliabilityPolicy, names["reliability"]),
        durability=getattr(DurabilityPolicy, names["durability"]),
    )


def message_class(topic: Topic) -> Any:
    """The Python message class of a topic's ``package/msg/Type`` (imports the interface package)."""
    package, _, cls = topic.type.split("/")
    return getattr(importlib.import_module(f"{package}.msg"), cls)
