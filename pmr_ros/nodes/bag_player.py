"""``pmr_bag_player``: publishes a bag's messages on their topics in simulated-time lockstep.

Messages go out in recording order with the contract's QoS, CDR bytes as
recorded, sample by sample (a sample begins with its clock message).  Lockstep
by default: the player is a producer of the flow control
(:mod:`pmr_ros.ros.flow`) and publishes a sample only once every lockstep
consumer (a diagnostician, a recorder: the publishers of ``pmr/progress``, in
this process or any other) has taken the one ``max_samples_ahead`` samples
back, so it runs as fast as its slowest consumer and none loses a sample.
A ``max_samples_per_s`` pace may be added (for subscribers that do not report
progress); with a ``rate``, the recorded receive times are reproduced
(``rate`` 1.0 = the recorded pace, 2.0 = twice as fast).

The bag's topics are read in the namespace the bag recorded (``/pmr/...``,
``/column_a/pmr/...``) and published under the contract's relative names in
the player node's own namespace, so a bag of one node set can be replayed to
another.  By default the diagnostician's own outputs (/diagnostics,
pmr/estimates) are not replayed: a live diagnostician listening to the replay
publishes its own.  The recorded run configuration goes out first on the
latched pmr/run_config.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator

from rclpy.duration import Duration
from rclpy.node import Node

from ..bag.offline import bag_namespace
from ..bag.reader import Bag, BagMessage
from ..bag.storage import RUN_CONFIG_KEY, BagError, typestore
from ..config.schema import parameters
from ..contract.topics import PROGRESS_KEY, SIGNAL_TOPICS, Topic, load_contract
from ..ros.convert import run_complete_message
from ..ros.flow import ProgressGate, cdr_stamp_ns
from ..ros.followers import FollowerWatch
from ..ros.messages import message_class, qos_profile

NODE_NAME = "pmr_bag_player"
DIAGNOSTICIAN_OUTPUTS = ("diagnostics", "estimates", "proposed_model")
"""Contract keys not replayed by default (a live diagnostician makes its own).  The controller's
``active_model`` is replayed like its u: a live diagnostician follows the recorded model switches."""


UNWATCHED = ("clock", "active_model", RUN_CONFIG_KEY)
"""Topics whose subscribers are not checked for missed samples: the clock (every sim-time node hears it;
a skipped tick loses no data) and the latched model and configuration (only the newest message matters)."""


def default_max_ahead() -> int:
    """The declared ``simulation.max_samples_ahead`` (the player holds back as the plant does) [samples]."""
    return int(parameters()["simulation.max_samples_ahead"].default)


def discovery_settle_s() -> float:
    """The declared ``simulation.discovery_settle_s``: how long a producer gives DDS to discover running nodes [s]."""
    return float(parameters()["simulation.discovery_settle_s"].default)


def replayed_topics(bag: Bag, include_outputs: bool = False, namespace: str = "/") -> dict[str, Topic]:
    """The bag's contract topics to publish: recorded name (in ``namespace``) -> contract topic.

    Raises
    ------
    BagError
        A contract topic in the bag has a type other than the contract's.
    """
    out = {}
    for key, t in load_contract().items():
        name = t.resolved(namespace)
        if key == PROGRESS_KEY or name not in bag.topics:
            continue
        if bag.topics[name] != t.type:
            raise BagError(f"{bag.path}: topic {name} has type {bag.topics[name]}, the contract says {t.type}")
        if include_outputs or key not in DIAGNOSTICIAN_OUTPUTS:
            out[name] = t
    return out


def samples(bag: Bag, topics: set[str], clock_topic: str) -> Iterator[list[BagMessage]]:
    """The bag's messages of ``topics`` grouped by sample: each group starts at a clock message.

    But the first when messages came before the first clock (the controller's
    latched ``pmr/active_model``, published at its start): they make a group of
    their own.
    """
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
        Also replay the diagnostician's outputs (diagnostics, pmr/estimates, pmr/proposed_model).
    publish_config : bool
        Publish the recorded run configuration (latched) first.
    max_ahead : int, optional
        Lockstep: hold back until every consumer has taken the sample this many back
        [samples]; default ``simulation.max_samples_ahead``.
    **kwargs
        For :class:`rclpy.node.Node` (``context``, ``namespace``: where the topics go).

    Attributes
    ----------
    published : dict
        Recorded topic name -> messages published.
    gate : ProgressGate
    """

    def __init__(
        self,
        bag: Bag,
        *,
        include_outputs: bool = False,
        publish_config: bool = True,
        max_ahead: int | None = None,
        node_name: str = NODE_NAME,
        **kwargs,
    ) -> None:
        super().__init__(node_name, start_parameter_services=False, **kwargs)
        self.bag = bag
        source = bag_namespace(bag)
        contract = load_contract()
        self.topics = replayed_topics(bag, include_outputs, source)
        self.config_topic = contract[RUN_CONFIG_KEY].resolved(source)
        if not publish_config:
            self.topics.pop(self.config_topic, None)
        self._outlets = {name: self._publisher(t) for name, t in self.topics.items()}
        self.published = dict.fromkeys(self.topics, 0)
        self.clock_topic = contract["clock"].resolved(source)
        self._signals = [contract[key].name for key in SIGNAL_TOPICS.values()]
        self.gate = ProgressGate(self, max_ahead=max_ahead or default_max_ahead(), on_change=lambda: None)
        self._end_pub = self._publisher(contract["run_complete"])
        watched = {contract[t.key].name: t.qos.depth for t in self.topics.values() if t.key not in UNWATCHED}
        self.followers = FollowerWatch(self, watched, self.gate.consumers)
        if publish_config:
            self._publish_config()

    def _publisher(self, t: Topic):
        relative = load_contract()[t.key]
        return self.create_publisher(message_class(relative), relative.name, qos_profile(relative.qos))

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
            self._outlets[self.config_topic] = self._publisher(t)
            self.published[self.config_topic] = 0
        data = typestore().serialize_cdr(
            typestore().types["std_msgs/msg/String"](data=config.to_text()), "std_msgs/msg/String"
        )
        self._send(self.config_topic, bytes(data))

    def _send(self, name: str, data: bytes) -> None:
        self._outlets[name].publish(data)
        self.published[name] += 1

    def subscribers(self, name: str) -> int:
        """Subscribers matched on the topic the recorded topic ``name`` is published to."""
        return self._outlets[name].get_subscription_count()

    def signal_topics(self) -> list[str]:
        """The recorded names of the bag's r, u and y topics."""
        return [n for n, t in self.topics.items() if t.key in SIGNAL_TOPICS.values()]

    def wait_for_subscribers(self, names: list[str], timeout_s: float, spin: Callable[[], None]) -> bool:
        """Wait until every recorded topic of ``names`` has a subscriber (or ``timeout_s`` passed)."""
        deadline = time.monotonic() + timeout_s
        while any(self.subscribers(n) == 0 for n in names if n in self._outlets):
            if time.monotonic() > deadline:
                return False
            spin()
        return True

    def silent_subscribers(self) -> list[str]:
        """Nodes subscribed to r, u or y that do not report progress (they may fall behind and lose samples)."""
        return self.gate.silent_subscribers(self._signals)

    def wait_for_consumers(self, timeout_s: float, spin: Callable[[], None]) -> list[str]:
        """Wait until every subscriber of r, u and y reports progress; those that still do not."""
        deadline = time.monotonic() + timeout_s
        while (silent := self.silent_subscribers()) and time.monotonic() < deadline:
            spin()
        return silent

    def play(
        self,
        *,
        rate: float | None = None,
        max_samples_per_s: float | None = None,
        spin: Callable[[float], None] | None = None,
        after_sample: Callable[[int], None] | None = None,
        should_stop: Callable[[], bool] | None = None,
    ) -> int:
        """Publish every sample of the bag; the number of samples published.

        Parameters
        ----------
        rate : float, optional
            None: lockstep; else the recorded pace times ``rate`` (no flow control).
        max_samples_per_s : float or None
            Lockstep: also at most this many samples per second of wall time
            [samples/s]; None: as fast as the consumers take them.
        spin : callable, optional
            ``spin(timeout_s)`` runs this node's callbacks (the consumers'
            progress reports); lockstep waits for them only when given.
        after_sample : callable, optional
            Called with the count of samples sent after each one.
        should_stop : callable, optional
            Polled between samples; True ends the replay early.
        """
        names = set(self.topics) - {self.config_topic}
        count, last_stamp = 0, None
        pace = _Pace(rate, max_samples_per_s)
        for group in samples(self.bag, names, self.clock_topic):
            if should_stop is not None and should_stop():
                break
            if not self._hold_back(rate, spin, should_stop):
                break
            pace.wait(count, group[0].log_time_ns)
            for message in group:
                self._send(message.topic, message.data)
            stamp = self._sample_stamp(group)
            if stamp is None:
                continue  # what came before the first sample (the controller's latched model): no sample
            self.gate.published(stamp)
            self.followers.published(stamp)
            count, last_stamp = count + 1, stamp
            if after_sample is not None:
                after_sample(count)
        else:
            if last_stamp is not None:  # the whole bag went out: its end is the run's end for the consumers
                self._end_pub.publish(run_complete_message(last_stamp * 1e-9))
        self.wait_for_acks(2.0)
        self.followers.look()
        return count

    def _sample_stamp(self, group: list[BagMessage]) -> int | None:
        """The stamp of the sample a group of messages is [ns]; None for messages before the first sample.

        Read from the group's first clock or r, u, y message (each opens with its
        stamp); a latched model topic recorded before the first clock has none.
        """
        stamped = {self.clock_topic, *self.signal_topics()}
        first = next((m for m in group if m.topic in stamped), None)
        return None if first is None else cdr_stamp_ns(first.data)

    def _hold_back(
        self, rate: float | None, spin: Callable[[float], None] | None, should_stop: Callable[[], bool] | None
    ) -> bool:
        """Lockstep: spin until the consumers let the next sample go; False when stopped meanwhile."""
        if rate is not None or spin is None:
            return True
        while not self.gate.open():
            if should_stop is not None and should_stop():
                return False
            spin(0.01)
        return True

    def wait_for_acks(self, timeout_s: float) -> bool:
        """Wait until every subscriber has acknowledged everything published (reliable QoS)."""
        return all(p.wait_for_all_acked(Duration(seconds=timeout_s)) for p in self._outlets.values())

    def destroy_node(self) -> None:
        """Stop the flow control's timer, then destroy the node."""
        self.gate.destroy()
        super().destroy_node()


class _Pace:
    """Sleeps so samples go out at a recorded pace (``rate``) or at most ``max_samples_per_s``."""

    def __init__(self, rate: float | None, max_samples_per_s: float | None) -> None:
        self.rate, self.limit = rate, max_samples_per_s
        self.start: float | None = None
        self.first_log: int | None = None

    def wait(self, count: int, log_time_ns: int) -> None:
        """Sleep until sample number ``count`` (logged at ``log_time_ns``) is due."""
        if self.rate is None and not self.limit:
            return
        self.start = time.monotonic() if self.start is None else self.start
        if self.rate is not None:
            self.first_log = log_time_ns if self.first_log is None else self.first_log
            due = (log_time_ns - self.first_log) * 1e-9 / self.rate
        else:
            due = count / float(self.limit or 1.0)
        ahead = due - (time.monotonic() - self.start)
        if ahead > 0:
            time.sleep(ahead)
