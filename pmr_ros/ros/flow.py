"""Lockstep flow control over ``pmr/progress``: consumers report what they took, producers hold back.

A DDS reader's history is bounded (the signal topics keep the newest 1000
messages) and a reliable acknowledgement only says a message *arrived* there,
not that the node *took* it; a consumer that falls further behind loses the
oldest unread samples.  So every lockstep consumer (the diagnostician, a bag
recorder) reports on ``pmr/progress`` the newest sample it has taken from every
signal topic it reads (:class:`ProgressReporter`), and a lockstep producer (the
plant, the bag player) publishes a sample only while every consumer it knows
is at most ``simulation.max_samples_ahead`` samples behind
(:class:`ProgressGate`).  Consumers are the publishers of ``pmr/progress`` in
the ROS graph (and whoever reported), so they may live in other processes,
and a consumer that goes away stops holding anyone back.  Stamps are compared
in integer nanoseconds, exactly as they travel.  msg_defs/README.md, "Flow
control", has the design and why DDS's own KEEP_ALL history was not used.
"""

from __future__ import annotations

import struct
import time
from collections import deque
from collections.abc import Callable, Iterable
from typing import Any

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from std_msgs.msg import Header

from ..contract.topics import PROGRESS_KEY, topic
from .messages import qos_profile

__all__ = [
    "REPORT_EVERY_MESSAGES",
    "REPORT_PERIOD_S",
    "ProgressGate",
    "ProgressReporter",
    "cdr_stamp_ns",
    "stamp_ns",
]

REPORT_EVERY_MESSAGES = 24
"""A consumer reports after taking this many messages (8 samples of r, u and y)."""

REPORT_PERIOD_S = 0.05
"""... and at least this often while its progress changes [s of wall time]."""

REPEAT_PERIOD_S = 0.5
"""An unchanged progress is repeated this often, so no single lost report can hold a producer [s]."""

GRAPH_REFRESH_S = 0.25
"""How often a producer reads the consumers from the ROS graph [s of wall time]."""

WAIT_WARNING_S = 5.0
"""A producer held back this long names the consumer it waits for (and again after as long) [s]."""

_CDR_LITTLE_ENDIAN = (0x00, 0x01)


def stamp_ns(stamp: Any) -> int:
    """A ``builtin_interfaces/Time`` as integer nanoseconds (exact, unlike float seconds)."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def cdr_stamp_ns(data: bytes | memoryview) -> int:
    """The time stamp that opens a CDR-serialised message [ns].

    A ``JointState`` begins with its ``header.stamp``, a ``rosgraph_msgs/Clock``
    with its ``clock``: both a ``builtin_interfaces/Time`` right after the
    4-byte encapsulation header, so a recorder reads the stamp without
    deserialising the message.

    Raises
    ------
    ValueError
        Fewer than 12 bytes.
    """
    if len(data) < 12:
        raise ValueError(f"a CDR message of {len(data)} bytes has no time stamp")
    little = bytes(data[0:2]) == bytes(_CDR_LITTLE_ENDIAN)
    sec, nanosec = struct.unpack_from("<iI" if little else ">iI", data, 4)
    return sec * 1_000_000_000 + nanosec


class ProgressReporter:
    """A lockstep consumer's reports on ``pmr/progress``.

    The progress is the oldest of the newest stamps taken per topic: the
    newest sample the consumer holds of every signal.  Nothing is reported
    until every topic has delivered a message.

    Parameters
    ----------
    node : rclpy.node.Node
        The consuming node (its fully qualified name identifies it).
    topics : iterable of str
        Keys of the topics the consumer reads (signal names or topic names).
    hold : callable, optional
        Asked before each report: True holds it back (the consumer has work
        queued), so producers stop ``max_samples_ahead`` samples ahead.

    Attributes
    ----------
    held : bool
        While True nothing is reported (the consumer is stopping), so
        producers stop once they are ``max_samples_ahead`` ahead.
    reports : int
        Reports sent.
    """

    def __init__(self, node: Node, topics: Iterable[str], *, hold: Callable[[], bool] | None = None) -> None:
        t = topic(PROGRESS_KEY)
        self._hold = hold
        self._node = node
        self._name = node.get_fully_qualified_name()
        self._pub = node.create_publisher(Header, t.name, qos_profile(t.qos))
        self._newest: dict[str, int | None] = dict.fromkeys(topics)
        self._since_report = 0
        self._reported: int | None = None
        self._reported_at = 0.0
        self.held = False
        self.reports = 0
        wall = Clock(clock_type=ClockType.STEADY_TIME)
        self._timer = node.create_timer(REPORT_PERIOD_S, self._on_timer, clock=wall)

    @property
    def progress_ns(self) -> int | None:
        """The newest stamp taken on every topic [ns]; None until each has delivered a message.

        A topic whose first messages are still on their way (its subscription
        matched later than the others') holds the report back, so a producer
        cannot run ahead of it before it is there.
        """
        newest = list(self._newest.values())
        return None if any(ns is None for ns in newest) else min(ns for ns in newest if ns is not None)

    def took(self, key: str, stamp: int) -> None:
        """Note that a message of ``key`` stamped ``stamp`` [ns] was taken (good or rejected)."""
        newest = self._newest[key]
        if newest is None or stamp > newest:
            self._newest[key] = stamp
        self._since_report += 1
        if self._since_report >= REPORT_EVERY_MESSAGES:
            self.report()

    def report(self, *, repeat: bool = False) -> None:
        """Publish the progress if it changed (or ``repeat``), unless held."""
        progress = self.progress_ns
        if self.held or progress is None or (progress == self._reported and not repeat):
            return
        if self._hold is not None and self._hold():
            return
        msg = Header(frame_id=self._name)
        msg.stamp.sec, msg.stamp.nanosec = divmod(progress, 1_000_000_000)
        self._pub.publish(msg)
        self._since_report = 0
        self._reported = progress
        self._reported_at = time.monotonic()
        self.reports += 1

    def _on_timer(self) -> None:
        self.report(repeat=time.monotonic() - self._reported_at >= REPEAT_PERIOD_S)

    def destroy(self) -> None:
        """Stop the timer (the node's destruction removes the publisher from the graph)."""
        self._timer.cancel()
        self._node.destroy_timer(self._timer)


class ProgressGate:
    """Holds a lockstep producer back while a consumer is more than ``max_ahead`` samples behind.

    The producer calls :meth:`published` with each sample's stamp and asks
    :meth:`open` before the next; ``on_change`` is called whenever a report
    arrives or the graph is re-read, so a waiting producer can go on.  The
    first sample (after :meth:`reset`) must be taken by every consumer before
    the second goes out; from then on the producer runs up to ``max_ahead``
    samples ahead.

    Parameters
    ----------
    node : rclpy.node.Node
        The producing node.
    max_ahead : int
        Sample k goes out only once every consumer has taken sample ``k - max_ahead`` [samples].
    on_change : callable
        Called (on the executor's thread) when the gate may have opened.
    """

    def __init__(self, node: Node, *, max_ahead: int, on_change: Callable[[], None]) -> None:
        t = topic(PROGRESS_KEY)
        self.max_ahead = int(max_ahead)
        self._node = node
        self._topic = node.resolve_topic_name(t.name)
        self._on_change = on_change
        self._acks: dict[str, int] = {}
        self._graph: set[str] = set()
        self._graph_read = -GRAPH_REFRESH_S
        self._sent: deque[int] = deque(maxlen=self.max_ahead)
        self._closed_since: float | None = None
        self._warned_at = 0.0
        self.waits = 0
        self._sub = node.create_subscription(Header, t.name, self._on_report, qos_profile(t.qos))
        wall = Clock(clock_type=ClockType.STEADY_TIME)
        self._timer = node.create_timer(GRAPH_REFRESH_S, self._on_timer, clock=wall)

    # -- consumers -------------------------------------------------------------
    def _on_report(self, msg: Header) -> None:
        name, ns = msg.frame_id, stamp_ns(msg.stamp)
        if ns > self._acks.get(name, -1):
            self._acks[name] = ns
            self._on_change()

    def _read_graph(self, *, now: float) -> None:
        if now - self._graph_read < GRAPH_REFRESH_S:
            return
        self._graph_read = now
        infos = self._node.get_publishers_info_by_topic(self._topic)
        self._graph = {_qualified(i.node_namespace, i.node_name) for i in infos}

    def consumers(self) -> dict[str, int | None]:
        """Every consumer now in the graph and the newest stamp it reported [ns] (None: nothing yet)."""
        self._read_graph(now=time.monotonic())
        return {name: self._acks.get(name) for name in sorted(self._graph)}

    def matched(self) -> bool:
        """Whether this producer's subscription has matched every consumer now in the graph.

        The graph names a consumer before the DDS endpoints match; its kept reports (transient local) reach the
        producer only after the match, so a restarted producer judges "is a run under way?" only then.
        """
        return self._sub.get_publisher_count() >= len(self.consumers())

    def _on_timer(self) -> None:
        self._read_graph(now=time.monotonic())
        self._on_change()

    def silent_subscribers(self, topics: Iterable[str], *, exclude: Iterable[str] = ()) -> list[str]:
        """Nodes subscribed to any of ``topics`` that are not (yet) consumers in the graph.

        Before a producer starts it waits until this is empty (but for the
        ``exclude``d nodes, e.g. the controller, which the loop holds anyway):
        a consumer whose progress writer is not discovered yet would not hold
        the producer back.  A third-party subscriber never reports; the
        producer names it and goes on after its start-up timeout.
        """
        nodes: set[str] = set()
        for name in topics:
            infos = self._node.get_subscriptions_info_by_topic(self._node.resolve_topic_name(name))
            nodes.update(_qualified(i.node_namespace, i.node_name) for i in infos)
        self._graph_read = -GRAPH_REFRESH_S  # read the consumers afresh too
        return sorted(nodes - set(self.consumers()) - set(exclude))

    # -- the producer's side ---------------------------------------------------
    def published(self, stamp: int) -> None:
        """Note that the sample stamped ``stamp`` [ns] went out."""
        self._sent.append(stamp)

    def behind(self) -> dict[str, int | None]:
        """The consumers that have not yet taken the sample needed for the next (name -> reported stamp).

        The sample ``max_ahead`` back; until that many went out, the first one:
        every consumer must have taken the first sample on every topic before
        the producer runs ahead (a subscription that matched late is there then).
        """
        if not self._sent:
            return {}
        needed = self._sent[0]
        return {n: ack for n, ack in self.consumers().items() if ack is None or ack < needed}

    def open(self) -> bool:
        """Whether the next sample may go out now (warns when it has been closed for long)."""
        waiting = self.behind()
        now = time.monotonic()
        if not waiting:
            self._closed_since = None
            return True
        if self._closed_since is None:
            self._closed_since, self._warned_at = now, now
            self.waits += 1
        elif now - self._warned_at >= WAIT_WARNING_S:
            self._warned_at = now
            self._node.get_logger().warning(self.describe_wait(waiting, now - self._closed_since))
        return False

    def describe_wait(self, waiting: dict[str, int | None], seconds: float) -> str:
        """One line naming the consumers a producer waits for and what they reported."""
        parts = [
            f"{name} ({'nothing yet' if ns is None else f'has taken {ns * 1e-9:.9g} s'})"
            for name, ns in waiting.items()
        ]
        return (
            f"lockstep: held back for {seconds:.1f} s until {', '.join(parts)} takes the sample stamped "
            f"{self._sent[0] * 1e-9:.9g} s ({self.max_ahead} samples back); a stopped consumer holds the producer "
            f"until it leaves the ROS graph"
        )

    def reset(self) -> None:
        """Forget the samples sent (a producer that jumps to another sample, e.g. a resumed plant)."""
        self._sent.clear()
        self._closed_since = None

    def destroy(self) -> None:
        """Stop the graph timer."""
        self._timer.cancel()
        self._node.destroy_timer(self._timer)


def _qualified(namespace: str, name: str) -> str:
    return f"{namespace.rstrip('/')}/{name}"
