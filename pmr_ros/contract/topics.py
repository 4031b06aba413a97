"""The topic contract of ``msg_defs/topics.yaml``: names, message types, QoS, field meanings.

Nodes, bags and tests take topic names, types and QoS from here, never from
literals.  Plain data: the rclpy and ``rosbags`` forms of a QoS are made from
:meth:`TopicQos.policies` by :mod:`pmr_ros.ros.messages` and :mod:`pmr_ros.bag.storage`.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace
from functools import cache
from pathlib import Path

import yaml

from ..config.fast_yaml import load as load_yaml_text
from ..resources import share_dir

__all__ = [
    "CONTRACT_FILE",
    "PROGRESS_KEY",
    "SIGNAL_TOPICS",
    "DISTURBANCE_TOPIC",
    "ContractError",
    "Topic",
    "TopicQos",
    "check_namespace",
    "load_contract",
    "msg_defs_dir",
    "namespaces_of",
    "parse_contract",
    "resolve_name",
    "topic",
]

CONTRACT_FILE = "topics.yaml"
RELIABILITIES = ("reliable", "best_effort")
DURABILITIES = ("transient_local", "volatile")
HISTORIES = ("keep_last", "keep_all")

SIGNAL_TOPICS = {"r": "setpoint", "u": "manipulated_input", "y": "measured_output"}
"""Contract keys of the signals the diagnostician aligns: setpoints r, inputs u, outputs y."""

DISTURBANCE_TOPIC = "disturbance"
"""Contract key of the measured disturbances v(k), aligned as ``dv`` beside r, u, y when the system has DVs."""

PROGRESS_KEY = "progress"
"""Contract key of the lockstep consumers' progress reports (flow control; never recorded in bags)."""


class ContractError(ValueError):
    """``msg_defs/topics.yaml`` is malformed; the message names the topic and field."""


def msg_defs_dir() -> Path:
    """The folder with the topic contract (see :func:`pmr_ros.resources.share_dir`)."""
    return share_dir("msg_defs", CONTRACT_FILE)


@dataclass(frozen=True)
class TopicQos:
    """QoS of a topic as written in the contract.

    Attributes
    ----------
    reliability : str
        ``reliable`` or ``best_effort``.
    durability : str
        ``transient_local`` or ``volatile``.
    depth : int
        History depth (of ``keep_last``; the resource bound of ``keep_all``).
    history : str
        ``keep_last`` or ``keep_all``.
    """

    reliability: str
    durability: str
    depth: int
    history: str = "keep_last"

    def policies(self) -> dict[str, str]:
        """Policy kind to its enum member name, as rclpy and rosbags both spell them (``KEEP_LAST``)."""
        return {
            "history": self.history.upper(),
            "reliability": self.reliability.upper(),
            "durability": self.durability.upper(),
        }


@dataclass(frozen=True)
class Topic:
    """One topic of the contract.

    Attributes
    ----------
    key : str
        The contract's key (``setpoint``, ``measured_output``, ...).
    name : str
        The ROS topic name, relative (``pmr/setpoint``): a node resolves it in
        its namespace, so ``-r __ns:=/column_a`` moves a whole node set; see
        :meth:`resolved` for the absolute name.
    type : str
        The interface, ``package/msg/Type``.
    qos : TopicQos
    description : str
    fields : dict
        Field path to its meaning and unit.
    """

    key: str
    name: str
    type: str
    qos: TopicQos
    description: str
    fields: dict

    def resolved(self, namespace: str = "/") -> str:
        """The absolute topic name in ``namespace`` (``/column_a/pmr/setpoint``); see :func:`resolve_name`."""
        return resolve_name(self.name, namespace)

    def in_namespace(self, namespace: str = "/") -> Topic:
        """The topic with its absolute name in ``namespace`` (as a bag records it)."""
        return replace(self, name=self.resolved(namespace))


def resolve_name(name: str, namespace: str = "/") -> str:
    """The absolute name of topic ``name`` for a node in ``namespace``, as rcl expands it.

    Parameters
    ----------
    name : str
        Absolute (``/clock``, left as it is) or relative (``pmr/setpoint``).
    namespace : str
        A node namespace, ``/`` or ``/column_a`` (a trailing ``/`` and a
        missing leading one are tolerated: ``column_a/`` is ``/column_a``).

    Returns
    -------
    str
    """
    if name.startswith("/"):
        return name
    parts = [p for p in namespace.strip().split("/") if p]
    return "/" + "/".join([*parts, name])


def namespaces_of(key: str, names: Iterable[str]) -> list[str]:
    """The namespaces in which contract topic ``key`` is among the absolute topic ``names`` (a bag's).

    ``/column_a/pmr/setpoint`` gives ``/column_a``, ``/pmr/setpoint`` gives ``/``.
    """
    relative = topic(key).name
    found = set()
    for name in names:
        if name == "/" + relative:
            found.add("/")
        elif name.endswith("/" + relative):
            found.add(name[: -len(relative) - 1])
    return sorted(found)


def check_namespace(text: str) -> str:
    """A node namespace as given by a user (``column_a``, ``/plant/column_a``), made absolute.

    Raises
    ------
    ContractError
        Not a valid ROS namespace (tokens of letters, digits and ``_``, not
        starting with a digit).
    """
    parts = [p for p in text.strip().split("/") if p]
    for part in parts:
        if not part.replace("_", "a").isalnum() or not part.isascii() or part[0].isdigit():
            raise ContractError(
                f"namespace {text!r}: {part!r} is not a valid name (letters, digits and _, not starting with a digit)"
            )
    return "/" + "/".join(parts)


def _choice(where: str, field: str, value: object, choices: tuple[str, ...]) -> str:
    if value not in choices:
        raise ContractError(f"{where}.{field} = {value!r}: must be one of {', '.join(choices)}")
    return str(value)


def _qos(where: str, qos: object) -> TopicQos:
    if not isinstance(qos, dict):
        raise ContractError(f"{where}.qos: must be a mapping")
    reliability = _choice(where, "qos.reliability", qos.get("reliability"), RELIABILITIES)
    durability = _choice(where, "qos.durability", qos.get("durability"), DURABILITIES)
    history = _choice(where, "qos.history", qos.get("history", "keep_last"), HISTORIES)
    depth = qos.get("depth")
    if isinstance(depth, bool) or not isinstance(depth, int) or depth < 1:
        raise ContractError(f"{where}.qos.depth = {depth!r}: must be a whole number >= 1")
    return TopicQos(reliability, durability, depth, history)


def _topic(key: str, entry: object, where: str) -> Topic:
    if not isinstance(entry, dict):
        raise ContractError(f"{where}: must be a mapping")
    for field in ("name", "type", "qos", "description", "fields"):
        if field not in entry:
            raise ContractError(f"{where}.{field}: missing")
    name, type_name = entry["name"], entry["type"]
    if not isinstance(name, str) or not name or name.startswith("~"):
        raise ContractError(f"{where}.name = {name!r}: must be a topic name")
    if not isinstance(type_name, str) or type_name.count("/") != 2 or type_name.split("/")[1] != "msg":
        raise ContractError(f"{where}.type = {type_name!r}: must be 'package/msg/Type'")
    if not isinstance(entry["fields"], dict) or not entry["fields"]:
        raise ContractError(f"{where}.fields: must document every field")
    return Topic(key, name, type_name, _qos(where, entry["qos"]), str(entry["description"]), dict(entry["fields"]))


def parse_contract(doc: dict, source: str = CONTRACT_FILE) -> dict[str, Topic]:
    """Validate a contract document into topics by key.

    Raises
    ------
    ContractError
        Naming the topic and the field that is wrong.
    """
    if not isinstance(doc, dict) or not isinstance(doc.get("topics"), dict):
        raise ContractError(f"{source}: expected a mapping with a 'topics' mapping")
    return {key: _topic(key, entry, f"{source}: topics.{key}") for key, entry in doc["topics"].items()}


@cache
def load_contract(path: str | None = None) -> dict[str, Topic]:
    """The topics of ``msg_defs/topics.yaml`` (or ``path``), by key."""
    file = Path(path) if path else msg_defs_dir() / CONTRACT_FILE
    try:
        doc = load_yaml_text(file.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise ContractError(f"{file}: cannot read the topic contract: {exc}") from None
    return parse_contract(doc, str(file))


def topic(key: str) -> Topic:
    """One topic of the shipped contract by its key (``setpoint``, ``diagnostics``, ...)."""
    topics = load_contract()
    if key not in topics:
        raise ContractError(f"no topic {key!r} in the contract; known: {', '.join(topics)}")
    return topics[key]
