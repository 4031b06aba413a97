"""``pmr_bag_player``: publishes a bag's messages on their topics in simulated-time lockstep.

Messages go out in recording order with the contract's QoS, CDR bytes as
recorded.  Sample by sample (a sample begins with its /clock message), in
lockstep by default at most :data:`DEFAULT_MAX_SAMPLES_PER_S`, so subscribers
in other processes are never overrun (waiting for reliable acknowledgements
does not help: they come with Fast DDS's heartbeats, every 3 s, and only say
a message arrived, not that it was processed); in one process a test spins the subscriber after each sample
(``after_sample``) and replays strictly in lockstep, unthrottled.  With a
``rate``, the recorded receive times are reproduced (``rate`` 1.0 = the
recorded pace, 2.0 = twice as fast).

By default the diagnostician's own outputs (/diagnostics, /pmr/estimates) are
not replayed: a live diagnostician listening to the replay publishes its own.
The recorded run configuration goes out first on the latched /pmr/run_config.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator

from rclpy.duration import Duration
from rclpy.node import Node

from ..bag.reader import Bag, BagMessage
from ..bag.schema import RUN_CONFIG_KEY, BagError, typestore
from ..contract.topics import load_contract
from ..ros.topics import message_class, qos_profile

NODE_NAME = "pmr_bag_player"
DEFAULT_MAX_SAMPLES_PER_S = 1000.0
"""Lockstep pace limit for subscribers in other processes [samples/s].

A subscriber cannot tell a publisher it has *processed* a message: reliable
QoS only acknowledges arrival in its history, and a keep-last history of the
contract's depth (1000) drops the oldest unread messages when its node falls
behind.  At 1000 samples/s a Python diagnostician (several thousand
samples/s) never falls that far behind, and the bag replays about as fast as
the lockstep node set recorded it."""
DIAGNOSTICIAN_OUTPUTS = ("diagnostics", "estimates")
"""Contract keys not replayed by default (a live diagnostician makes its own)."""


def replayed_topics(bag: Bag, include_outputs: bool = False) -> dict[str, str]:
    """Topic name -> type of the bag's contract topics to publish.

    Raises
    ------
    BagError
        A contract topic in the bag has a type other than the contract's.
    """
    out = {}
    for key, t in load_contract().items():
        if t.name not in bag.topics:
            continue
        if bag.topics[t.name] != t.type:
            raise BagError(f"{bag.path}: topic {t.name} has type {bag.topics[t.name]}, the contract says {t.type}")
        if include_outputs or key not in DIAGNOSTICIAN_OUTPUTS:
            out[t.name] = t.type
    return out


def samples(bag: Bag, topics: set[str], clock_topic: str) -> Iterator[list[BagMessage]]:
    """The bag's messages of ``topics`` grouped by sample: each group starts at a /clock message."""
    group: list[BagMessage] = []
    for message in bag.messages(topics):
        if message.topic == clock_topic and group:
            yield group
            group = []
        group.append(message)
    if group:
        yield group


class BagPlayerNode(Node):
    """Publishes the messages of a bag.

    Parameters
    ----------
    bag : Bag
    include_outputs : bool
        Also replay /diagnostics and /pmr/estimates.
    publish_config : bool
        Publish the recorded run configuration (latched) first.
    **kwargs
        For :class:`rclpy.node.Node` (``context``).

    Attributes
    ----------
    published : dict
        Topic name -> messages published.
    """

    def __init__(
        self,
        bag: Bag,
        *,
        include_outputs: bool = False,
        publish_config: bool = True,
        node_name: str = NODE_NAME,
        **kwargs,
    ) -> None:
        super().__init__(node_name, start_parameter_services=False, **kwargs)
        self.bag = bag
        contract = load_contract()
        self.topics = replayed_topics(bag, include_outputs)
        self.config_topic = contract[RUN_CONFIG_KEY].name
        if not publish_config:
            self.topics.pop(self.config_topic, None)
        by_name = {t.name: t for t in contract.values()}
        self._outlets = {
            name: self.create_publisher(message_class(by_name[name]), name, qos_profile(by_name[name].qos))
            for name in self.topics
        }
        self.published = dict.fromkeys(self.topics, 0)
        self.clock_topic = contract["clock"].name
        if publish_config:
            self._publish_config()

    def _publish_config(self) -> None:
        """The run configuration first (latched), from the topic or metadata.yaml."""
        if self.config_topic in self._outlets:
            for message in self.bag.messages({self.config_topic}):
                self._send(self.config_topic, message.data)
                return
        config = self.bag.run_config()
        if config is None:
            return
        t = load_contract()[RUN_CONFIG_KEY]
        if self.config_topic not in self._outlets:
            self._outlets[self.config_topic] = self.create_publisher(message_class(t), t.name, qos_profile(t.qos))
            self.published[self.config_topic] = 0
        data = typestore().serialize_cdr(
            typestore().types["std_msgs/msg/String"](data=config.to_text()), "std_msgs/msg/String"
        )
        self._send(self.config_topic, bytes(data))

    def _send(self, name: str, data: bytes) -> None:
        self._outlets[name].publish(data)
        self.published[name] += 1

    def subscribers(self, name: str) -> int:
        """Subscribers matched on topic ``name``."""
        return self._outlets[name].get_subscription_count()

    def wait_for_subscribers(self, names: list[str], timeout_s: float, spin: Callable[[], None]) -> bool:
        """Wait until every topic of ``names`` has a subscriber (or ``timeout_s`` passed)."""
        deadline = time.monotonic() + timeout_s
        while any(self.subscribers(n) == 0 for n in names if n in self._outlets):
            if time.monotonic() > deadline:
                return False
            spin()
        return True

    def play(
        self,
        *,
        rate: float | None = None,
        max_samples_per_s: float | None = DEFAULT_MAX_SAMPLES_PER_S,
        after_sample: Callable[[int], None] | None = None,
        should_stop: Callable[[], bool] | None = None,
    ) -> int:
        """Publish every sample of the bag; the number of samples published.

        Parameters
        ----------
        rate : float, optional
            None: lockstep, paced by ``max_samples_per_s``; else the recorded pace times ``rate``.
        max_samples_per_s : float or None
            Lockstep: at most this many samples per second of wall time
            [samples/s]; None: unbounded (only for subscribers known to keep
            up, or with ``after_sample`` spinning them).
        after_sample : callable, optional
            Called with the count of samples sent after each one (an in-process
            test spins the receiving node there: strict lockstep).
        should_stop : callable, optional
            Polled between samples; True ends the replay early.
        """
        names = set(self.topics) - {self.config_topic}
        count = 0
        first_log = start = None
        for group in samples(self.bag, names, self.clock_topic):
            if should_stop is not None and should_stop():
                break
            if rate is not None:
                first_log = group[0].log_time_ns if first_log is None else first_log
                start = time.monotonic() if start is None else start
                delay = (group[0].log_time_ns - first_log) * 1e-9 / rate - (time.monotonic() - start)
                if delay > 0:
                    time.sleep(delay)
            elif max_samples_per_s:
                start = time.monotonic() if start is None else start
                ahead = count / max_samples_per_s - (time.monotonic() - start)
                if ahead > 0:
                    time.sleep(ahead)
            for message in group:
                self._send(message.topic, message.data)
            count += 1
            if after_sample is not None:
                after_sample(count)
        self.wait_for_acks(2.0)
        return count

    def wait_for_acks(self, timeout_s: float) -> bool:
        """Wait until every subscriber has acknowledged everything published (reliable QoS)."""
        return all(p.wait_for_all_acked(Duration(seconds=timeout_s)) for p in self._outlets.values())
