"""The silence watchdog: which signals stopped, said once per timeout, never while the consumer is busy."""

import time

from pmr_ros.ros.silence import SilenceWatch

TIMEOUT_S = 0.1
LABELS = {"r": "r on /pmr/setpoint", "u": "u on /pmr/manipulated_input"}


def test_nothing_ever_received_is_said_as_such_and_not_as_a_list_of_topics():
    watch = SilenceWatch(("r", "u"), LABELS)
    assert watch.report(TIMEOUT_S) is None  # not yet silent for a timeout
    time.sleep(TIMEOUT_S * 1.5)
    reason, heard = watch.report(TIMEOUT_S)
    assert reason.startswith("no data received in ") and not heard


def test_the_silent_topic_is_named_once_per_timeout_and_a_new_sample_ends_the_silence():
    watch = SilenceWatch(("r", "u"), LABELS)
    watch.arrived("r")
    time.sleep(TIMEOUT_S * 1.5)
    watch.arrived("u")
    reason, heard = watch.report(TIMEOUT_S)
    assert heard and reason.startswith("no r on /pmr/setpoint for ") and "u on" not in reason
    assert watch.report(TIMEOUT_S) is None  # said once, not again before another timeout
    watch.arrived("r")
    time.sleep(TIMEOUT_S * 0.5)
    assert watch.report(TIMEOUT_S) is None


def test_a_busy_consumer_counts_silence_from_when_it_was_last_busy():
    watch = SilenceWatch(("r",), LABELS)
    watch.arrived("r")
    time.sleep(TIMEOUT_S * 1.5)
    watch.busy()
    assert watch.report(TIMEOUT_S) is None
    time.sleep(TIMEOUT_S * 1.5)
    assert watch.report(TIMEOUT_S)[0].startswith("no r on /pmr/setpoint for ")
