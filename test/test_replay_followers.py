"""A replay says which subscribers may have missed samples, and --strict fails on it (issue 21, item 4)."""

from __future__ import annotations

from types import SimpleNamespace

import pytest
from ros_fixtures import console_script
from test_bag_ros import EXPECTED, REFERENCE

from pmr_ros.cli import main
from pmr_ros.contract.topics import topic
from pmr_ros.ros.followers import FollowerWatch
from pmr_ros.ros.messages import message_class, qos_profile

SAMPLE_NS = 1_000_000_000


class _Graph:
    """The part of an rclpy node a :class:`FollowerWatch` reads, with a graph the test sets."""

    def __init__(self, subscribers: dict[str, list[str]]) -> None:
        self.subscribers = subscribers

    def resolve_topic_name(self, name: str) -> str:
        return name if name.startswith("/") else f"/{name}"

    def get_namespace(self) -> str:
        return "/"

    def get_name(self) -> str:
        return "pmr_bag_player"

    def get_subscriptions_info_by_topic(self, name: str):
        return [SimpleNamespace(node_namespace="/", node_name=n) for n in self.subscribers.get(name, [])]


def test_a_consumer_left_behind_is_counted_and_a_silent_subscriber_named():
    """The probe's numbers: a recorder took 2,375 of 8,192 samples; a listener on y alone never reports."""
    graph = _Graph({"/pmr/y": ["listener", "recorder", "pmr_bag_player"], "/pmr/r": ["recorder"]})
    progress: dict[str, int | None] = {"/recorder": None}
    watch = FollowerWatch(graph, {"pmr/y": 1000, "pmr/r": 1000}, lambda: dict(progress))
    for k in range(8192):
        if k == 2374:
            progress["/recorder"] = k * SAMPLE_NS  # its last report: then it stopped
        watch.published(k * SAMPLE_NS)
    watch.look()
    lines = watch.lines()
    assert len(lines) == 2, lines
    assert lines[0].startswith("/pmr/y: 1 subscriber(s) (/listener) do not report progress")
    assert "8192 were sent" in lines[0] and "--max-samples-per-second" in lines[0]
    assert lines[1] == "/recorder did not take the last 5817 of 8192 samples (it stopped or fell behind)"
    assert watch.behind() == {"/recorder": 8192 - 2375}


def test_consumers_that_took_everything_give_no_warning():
    graph = _Graph({"/pmr/y": ["diagnostician"]})
    progress = {"/diagnostician": 0}
    watch = FollowerWatch(graph, {"pmr/y": 1000}, lambda: dict(progress))
    for k in range(100):
        watch.published(k * SAMPLE_NS)
        progress["/diagnostician"] = k * SAMPLE_NS
    assert watch.caught_up() and watch.lines() == []


def test_the_replay_caps_max_samples_ahead_as_the_configuration_does(capsys):
    with pytest.raises(SystemExit) as end:
        main(["replay", str(REFERENCE), "--max-samples-ahead", "100000"])
    assert end.value.code == 2
    err = capsys.readouterr().err
    assert "--max-samples-ahead: 100000 must be >= 1 and <= 900 (the range of simulation.max_samples_ahead)" in err


@pytest.mark.ros
def test_a_slow_listener_on_y_alone_is_named_and_strict_fails(ros, tmp_path):
    """The probe: a third-party subscriber on y alone, at default settings, lost samples without a word."""
    import time

    t = topic("measured_output")
    got: list[int] = []

    def slow(msg) -> None:
        got.append(1)
        time.sleep(0.002)  # slower than an unpaced replay

    listener = ros.create_node("slow_listener")
    listener.create_subscription(message_class(t), t.name, slow, qos_profile(t.qos))
    log = tmp_path / "replay.log"
    proc = ros.start([console_script("pmr-ros"), "replay", str(REFERENCE), "--strict", "--wait", "3"], log)
    assert ros.spin_until(lambda: proc.poll() is not None, 300.0), "the replay did not end in 300 s"
    text = log.read_text()
    assert proc.wait(timeout=10) == 5, text
    assert f"{EXPECTED['samples']} samples" in text and "Traceback" not in text
    assert f"warning: {t.resolved()}: 1 subscriber(s) (/slow_listener) do not report progress" in text, text
    print(f"the slow listener got {len(got)} of {EXPECTED['samples']} samples")  # the loss the warning is about
