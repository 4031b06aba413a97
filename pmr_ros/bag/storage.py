"""What a pmr_ros bag holds: the contract's topics, their types and QoS, and the run's configuration.

A pmr_ros bag is an ordinary rosbag2 bag (MCAP by default, sqlite3 on
request).  It records every topic of ``msg_defs/topics.yaml`` (r, u, y,
/clock, /diagnostics, /pmr/estimates) plus the latched ``run_config`` topic, a
``std_msgs/String`` with the run's configuration as a ROS 2 params file.  The
same text goes into ``metadata.yaml``'s ``custom_data`` when the bag is closed;
the topic keeps it readable in a bag whose recorder was killed before it could
write ``metadata.yaml``.

No rclpy here: messages are (de)serialised with the pure-Python ``rosbags``
type store of ROS 2 Jazzy, so stock ``ros2 bag`` reads what is written.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cache
from typing import Any

import yaml

from .. import __version__
from ..config.fast_yaml import load as load_yaml_text
from ..contract.topics import PROGRESS_KEY, Topic, TopicQos, load_contract

__all__ = ["BagError", "RunConfig", "recorded_topics", "rosbags_qos", "typestore"]

RUN_CONFIG_KEY = "run_config"
"""Contract key of the latched topic with the run's configuration."""

CUSTOM_DATA_KEYS = (
    "pmr_ros.version",
    "pmr_ros.source",
    "pmr_ros.scenario",
    "pmr_ros.seed",
    "pmr_ros.samples",
    "pmr_ros.params",
)
"""Keys of the run's configuration in ``metadata.yaml`` ``custom_data`` (all strings)."""

MODEL_FILES_KEY = "pmr_ros.model_files"
"""``custom_data`` key of the curve files' texts (:mod:`.embedded_curves`), present when the run had any."""

STORAGES = ("mcap", "sqlite3")
"""Storage plugins a bag can be written with; MCAP is rosbag2's default since Iron."""


class BagError(Exception):
    """A bag cannot be read, written or used; the message says which and why (one line)."""


@cache
def typestore():
    """The ``rosbags`` type store of ROS 2 Jazzy (every common_interfaces message)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_JAZZY)


def recorded_topics(namespace: str = "/") -> dict[str, Topic]:
    """Every topic a bag records, by contract key, with its absolute name in ``namespace``.

    The whole contract but the flow control's progress reports (``PROGRESS_KEY``) and the end-of-run
    marker (``run_complete``: a replay sends its own after the bag's last sample).
    """
    unrecorded = (PROGRESS_KEY, "run_complete")
    return {k: t.in_namespace(namespace) for k, t in load_contract().items() if k not in unrecorded}


def rosbags_qos(qos: TopicQos) -> Any:
    """The contract's QoS as the ``rosbags`` QoS of a connection (``offered_qos_profiles``).

    Policy names come from :meth:`TopicQos.policies`, as for rclpy's profile.
    """
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

    names = qos.policies()
    return Qos(
        history=getattr(QosHistory, names["history"]),
        depth=qos.depth,
        reliability=getattr(QosReliability, names["reliability"]),
        durability=getattr(QosDurability, names["durability"]),
        deadline=QosTime(0, 0),
        lifespan=QosTime(0, 0),
        liveliness=QosLiveliness.AUTOMATIC,
        liveliness_lease_duration=QosTime(0, 0),
        avoid_ros_namespace_conventions=False,
    )


@dataclass(frozen=True)
class RunConfig:
    """The configuration a run was made with, as stored in its bag.

    Attributes
    ----------
    params : dict
        Every parameter the nodes ran with, nested (``system``, ``pmr``,
        ``run``, ``diagnostician``, ...), i.e. the merged params file.
    source : str
        The params file the run was configured from.
    version : str
        pmr_ros version that recorded the bag.
    model_files : dict
        The text of each curve file the parameters name, by the parameter's
        dotted name (``system.model_file``); left empty, the files are read at
        construction (:func:`~pmr_ros.bag.embedded_curves.model_file_texts`),
        so the bag keeps the curves the run had wherever it is read later.
    """

    params: dict
    source: str = ""
    version: str = field(default=__version__)
    model_files: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.model_files:
            from .embedded_curves import model_file_texts

            object.__setattr__(self, "model_files", model_file_texts(self.params))

    def curve_sets(self) -> dict[str, Any]:
        """The embedded curve files read, by dotted name: :func:`pmr_ros.config.parse_config`'s ``curves``.

        Raises
        ------
        BagError
            An embedded file that does not read (one line naming it).
        """
        from ..models.curve_set import ModelFileError
        from .embedded_curves import embedded_curve_sets

        try:
            return embedded_curve_sets(self.params, self.model_files)
        except ModelFileError as exc:
            raise BagError(f"the curve file recorded in the bag does not read: {exc}") from None

    @property
    def scenario(self) -> str:
        """The recorded ``run.scenario`` (empty when the run had none)."""
        return str(self.params.get("run", {}).get("scenario", ""))

    @property
    def seed(self) -> int | None:
        """The recorded ``run.seed``, if any."""
        return self.params.get("run", {}).get("seed")

    @property
    def samples(self) -> int | None:
        """The recorded ``run.samples``, if any."""
        return self.params.get("run", {}).get("samples")

    def params_yaml(self) -> str:
        """The parameters as a ROS 2 params file (``/**: ros__parameters:``)."""
        return yaml.safe_dump({"/**": {"ros__parameters": self.params}}, sort_keys=False)

    def to_text(self) -> str:
        """The document published on the ``run_config`` topic (YAML)."""
        files = {"pmr_ros_model_files": self.model_files} if self.model_files else {}
        return yaml.safe_dump(
            {
                "pmr_ros_run_config": {"version": self.version, "source": self.source},
                "/**": {"ros__parameters": self.params},
                **files,
            },
            sort_keys=False,
        )

    def custom_data(self) -> dict[str, str]:
        """``metadata.yaml`` custom_data entries (rosbag2 allows strings only)."""
        values = (self.version, self.source, self.scenario, str(self.seed), str(self.samples), self.params_yaml())
        out = dict(zip(CUSTOM_DATA_KEYS, values, strict=True))
        if self.model_files:
            out[MODEL_FILES_KEY] = yaml.safe_dump(self.model_files, sort_keys=False)
        return out

    @classmethod
    def from_text(cls, text: str) -> RunConfig:
        """Parse the ``run_config`` topic's document; raises :class:`BagError` if malformed."""
        try:
            doc = load_yaml_text(text)
            params = doc["/**"]["ros__parameters"]
            head = doc.get("pmr_ros_run_config", {}) or {}
        except (yaml.YAMLError, TypeError, KeyError) as exc:
            cause = " ".join(f"{type(exc).__name__}: {exc}".split())
            raise BagError(f"the recorded run configuration is not a pmr_ros params document ({cause})") from None
        if not isinstance(params, dict):
            raise BagError("the recorded run configuration has no parameter mapping under '/**: ros__parameters'")
        files = _texts(doc.get("pmr_ros_model_files"), "the recorded run configuration's pmr_ros_model_files")
        return cls(params, str(head.get("source", "")), str(head.get("version", "")), files)

    @classmethod
    def from_custom_data(cls, custom: dict[str, str]) -> RunConfig | None:
        """From ``metadata.yaml`` custom_data, or None when the bag has none."""
        text = (custom or {}).get("pmr_ros.params")
        if not text:
            return None
        try:
            params = load_yaml_text(text)["/**"]["ros__parameters"]
        except (yaml.YAMLError, TypeError, KeyError) as exc:
            cause = " ".join(f"{type(exc).__name__}: {exc}".split())
            raise BagError(f"metadata.yaml custom_data pmr_ros.params is not a params file ({cause})") from None
        where = f"metadata.yaml custom_data {MODEL_FILES_KEY}"
        try:
            files = _texts(load_yaml_text(custom[MODEL_FILES_KEY]) if custom.get(MODEL_FILES_KEY) else {}, where)
        except yaml.YAMLError:
            raise BagError(f"{where} is not YAML") from None
        return cls(params, custom.get("pmr_ros.source", ""), custom.get("pmr_ros.version", ""), files)


def _texts(value: Any, where: str) -> dict[str, str]:
    """The embedded curve files' mapping (dotted name -> text) as recorded; {} when absent.

    Raises
    ------
    BagError
        It is not a mapping of names to texts.
    """
    if value is None or value == {}:
        return {}
    if not isinstance(value, dict) or not all(isinstance(k, str) and isinstance(t, str) for k, t in value.items()):
        raise BagError(f"{where} is not a mapping of parameter names to file texts")
    return dict(value)
