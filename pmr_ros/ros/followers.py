"""Who may have missed samples of a lockstep producer: subscribers that never report, consumers left behind.

A lockstep producer (the bag player) holds back for the consumers that report
their progress on ``pmr/progress`` (:mod:`.flow`) and for no one else.  Any
other subscriber of its topics (``ros2 topic echo``, a third-party node, a
recorder of another tool) gets the samples only as long as it keeps up: its
reader keeps the newest ``depth`` messages, so one that falls further behind
loses the oldest unread ones without anyone being told.  A consumer that
reports can still end behind (it stopped, or left the graph mid-run).

:class:`FollowerWatch` looks at the graph while the producer publishes and
says, at the end, which subscribers of which topic may have missed samples
(a subscriber that does not report cannot be counted, only named) and how
many samples each reporting consumer did not take.
"""

from __future__ import annotations

from array import array
from bisect import bisect_right
from collections.abc import Callable

from rclpy.node import Node

__all__ = ["FollowerWatch"]

LOOK_EVERY_SAMPLES = 256
"""The graph is read again after this many samples (subscribers may come and go during a replay)."""


def _qualified(namespace: str, name: str) -> str:
    return f"{namespace.rstrip('/')}/{name}"


class FollowerWatch:
    """The subscribers of a producer's topics that may have missed samples.

    Parameters
    ----------
    node : rclpy.node.Node
        The producing node.
    topics : dict
        Topic names (as the node publishes them, relative or absolute) -> their
        history depth [messages].
    consumers : callable
        Returns the reporting consumers now in the graph and the newest stamp
        each reported [ns] (:meth:`.flow.ProgressGate.consumers`).
    """

    def __init__(self, node: Node, topics: dict[str, int], consumers: Callable[[], dict[str, int | None]]) -> None:
        self._node = node
        self._topics = {node.resolve_topic_name(name): depth for name, depth in topics.items()}
        self._consumers = consumers
        self._silent: dict[str, set[str]] = {}
        self._progress: dict[str, int | None] = {}
        self._stamps = array("q")

    def look(self) -> None:
        """Note every subscriber now in the graph that does not report, and every consumer's progress."""
        consumers = self._consumers()
        for name, ns in consumers.items():
            known = self._progress.get(name)
            self._progress[name] = ns if known is None or (ns is not None and ns > known) else known
        own = _qualified(self._node.get_namespace(), self._node.get_name())
        for topic in self._topics:
            infos = self._node.get_subscriptions_info_by_topic(topic)
            nodes = {_qualified(i.node_namespace, i.node_name) for i in infos} - set(consumers) - {own}
            if nodes:
                self._silent.setdefault(topic, set()).update(nodes)

    def published(self, stamp_ns: int) -> None:
        """Note that the sample stamped ``stamp_ns`` went out (the graph is read every :data:`LOOK_EVERY_SAMPLES`)."""
        self._stamps.append(stamp_ns)
        if len(self._stamps) % LOOK_EVERY_SAMPLES == 1:
            self.look()

    def behind(self) -> dict[str, int]:
        """Reporting consumers that did not take the last sample -> how many samples they did not take."""
        count = len(self._stamps)
        missed = {}
        for name, ns in self._progress.items():
            taken = 0 if ns is None else bisect_right(self._stamps, ns)
            if count and taken < count:
                missed[name] = count - taken
        return missed

    def caught_up(self) -> bool:
        """Whether every reporting consumer seen has taken the last sample (the graph read now)."""
        self.look()
        return not self.behind()

    def lines(self) -> list[str]:
        """One warning per topic with non-reporting subscribers and per consumer left behind; [] when none."""
        count = len(self._stamps)
        out = []
        for topic, seen in sorted(self._silent.items()):
            nodes = seen - set(self._progress)  # a consumer discovered after its subscription did report
            if not nodes:
                continue
            depth = self._topics[topic]
            out.append(
                f"{topic}: {len(nodes)} subscriber(s) ({', '.join(sorted(nodes))}) do not report progress on "
                f"pmr/progress, so the replay did not wait for them: each may have missed samples (a reader keeps "
                f"the newest {depth}; {count} were sent); pace the replay with --max-samples-per-second"
            )
        for name, missed in sorted(self.behind().items()):
            out.append(f"{name} did not take the last {missed} of {count} samples (it stopped or fell behind)")
        return out
