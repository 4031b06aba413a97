"""``pmr_diagnostician``: PMR verdicts per element on /diagnostics from r, u and y alone.

It subscribes to the setpoints, inputs (with their modes) and outputs and to nothing else, holds the controller's
model Ghat as parameters (so it can watch any controller), aligns the three signals by their sample stamps, keeps a
rolling window of the newest unbroken stretch and diagnoses it with :func:`pmr_ros.core.pmr.diagnosis.diagnose` every
``diagnostician.update_period_samples`` samples. One DiagnosticStatus per element goes to /diagnostics (OK / WARN /
ERROR; no numbers but the reason: STALE / WARN when the data do not support a verdict, ERROR when the diagnosis
raised), again every ``diagnostician.publish_period_s``; the estimates topic has the numbers of every verdict.

The diagnosis runs on a worker thread (:class:`~pmr_ros.ros.worker.SerialWorker`) on a snapshot of the window taken
when it was due, so the subscriptions are never starved and the verdict is the one the window had then. The node is a
lockstep consumer: it reports on ``pmr/progress`` how far it has taken r, u and y
(:class:`~pmr_ros.ros.flow.ProgressReporter`), holding the report back while diagnoses queue up, so a lockstep plant
or bag player never outruns it. It reports two publishers on one signal topic (another node set without its own
namespace, a stray publisher of old stamps): a message that repeats a stamp with other values, or comes out of order,
while the topic has two publishers suspends the verdicts (level ERROR, ``status: conflict``, the window restarted)
until no such message came for ``diagnostician.stale_timeout_s``. In real time, where nobody waits for it, every lost
sample is counted and reported with its topic and stamps.

With a verdict it closes the loop (:func:`pmr_ros.service.closing.close_window`, on the worker thread with the
diagnosis): the control impact of the mismatches goes into the statuses (each element's ``impact.*``, all together
``impact_all.*``), and when a mismatch verdict stands the corrected model is published, latched, on
``pmr/proposed_model``. It follows the controller's model: a new one on ``pmr/active_model`` becomes its own (the same
validated parameter change as ``set_parameters``) and only samples from the switch on are diagnosed against it.
"""

from __future__ import annotations

import time
from collections import deque
from functools import partial
from typing import Any

import numpy as np
from rclpy.clock import Clock, ClockType
from rclpy.parameter import Parameter

from ..config import ConfigError, PmrConfig, flatten_parameters
from ..config.write import configured_system_tree
from ..contract.alignment import MANUAL, SIGNALS, SampleAligner
from ..contract.failed_window import failed_window, failure_reason
from ..contract.layout import CONFLICT, FAILED, read_signal
from ..contract.layout import STALE as STALE_STATUS
from ..contract.model_topics import read_active_model
from ..contract.samples import sample_index
from ..contract.status_names import status_prefix
from ..contract.topics import DISTURBANCE_TOPIC, SIGNAL_TOPICS, topic
from ..contract.windowing import (
    STALE,
    VERDICT,
    Offer,
    check_window_memory,
    evaluate_window,
    offer_signal,
    without_verdict,
)
from ..core.results import Diagnosis
from ..ros.base import ConfiguredNode, run_node
from ..ros.convert import diagnosis_statuses, diagnostic_array, estimates_message, text_message
from ..ros.flow import ProgressReporter, stamp_ns
from ..ros.parameters import ros_value
from ..ros.silence import SilenceWatch
from ..ros.worker import SerialWorker
from ..service.closing import ClosedWindow, close_window
from ..service.memory_checks import check_impact_memory

_SIGNAL_TOPIC = {**SIGNAL_TOPICS, "dv": DISTURBANCE_TOPIC}
NODE_NAME = "pmr_diagnostician"

MAX_QUEUED_JOBS = 1
"""Diagnoses allowed to wait behind the running one before the node stops reporting progress."""


class PmrDiagnosticianNode(ConfiguredNode):
    """Rolling-window PMR diagnosis of any controller from its r, u and y.

    Attributes
    ----------
    aligner : SampleAligner
        The aligned samples and the bookkeeping of rejected messages.
    warnings : collections.deque of str
        The newest warnings (also logged), for tests and introspection.
    last_published : DiagnosticArray or None
    messages_received : int
        Messages of r, u and y taken, good or bad.
    lost_samples : dict
        Signal -> samples that never arrived (gaps in the stamps heard, rejected messages aside).
    progress : ProgressReporter
        Its reports on ``pmr/progress`` (lockstep flow control).
    worker : SerialWorker
        Runs the diagnoses (with the control impact and the proposal), publishes them, off the executor.
    model_since : int
        The first sample the controller ran on the current model (0 until a switch).
    last_proposal : str or None
        The newest proposed model published.
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(kwargs.pop("node_name", NODE_NAME), executable=NODE_NAME, live_parameters=True, **kwargs)
        self.warnings: deque[str] = deque(maxlen=1000)
        self.last_published = None
        self._silence: Any = None  # the statuses a silence's STALE statuses replaced (None: no silence now)
        self.messages_received = 0
        # with measured disturbances the window also needs v(k) of every sample (its D elements)
        self._signals = (*SIGNALS, "dv") if self.config.disturbance_model is not None else SIGNALS
        self.lost_samples = dict.fromkeys(self._signals, 0)
        self._heard: dict[str, int | None] = dict.fromkeys(self._signals)
        self._topics = {s: topic(_SIGNAL_TOPIC[s]).name for s in self._signals}
        self._labels = {s: f"{s} on {self.resolve_topic_name(self._topics[s])}" for s in self._signals}
        self.aligner = self._new_aligner()
        self._conflict: tuple[str, float] | None = None
        self.silence = SilenceWatch(self._signals, self._labels)
        self.run_complete = False  # the run is over (finish_run): its silence is no stale signal
        self.model_since = 0
        self.last_proposal: str | None = None
        self._impact_note = ""
        self.worker = SerialWorker("pmr_diagnosis", self._job_failed)
        self._diag_pub = self.contract_publisher("diagnostics")
        self._estimates_pub = self.contract_publisher("estimates")
        self._proposal_pub = self.contract_publisher("proposed_model")
        self._model_sub = self.contract_subscription("active_model", self._on_active_model)
        self._end_sub = self.contract_subscription("run_complete", self._on_run_complete)
        self._complete_at: int | None = None  # the last sample of a run its producer said was complete
        self.progress = ProgressReporter(self, self._signals, hold=lambda: self.worker.pending > 1 + MAX_QUEUED_JOBS)
        self._subs = [self.contract_subscription(_SIGNAL_TOPIC[s], partial(self._on_signal, s)) for s in self._signals]
        self._own_timers: list[Any] = []
        self._start_timers()

    # -- set-up --------------------------------------------------------------
    def check_start(self, config: PmrConfig) -> None:
        """A window or a control impact that cannot fit in memory is refused before the node starts (exit 2)."""
        check_window_memory(config, self._source)
        check_impact_memory(config, self._source)

    def _new_aligner(self) -> SampleAligner:
        model = self.config.model
        return SampleAligner(
            model.sample_time,
            self._channel_names(),
            self._labels,
            self.config.diagnostician.window_samples,
            self.config.diagnostician.max_lag_samples,
        )

    def _channel_names(self) -> dict[str, tuple[str, ...]]:
        model, dv = self.config.model, self.config.disturbance_model
        names = {"r": model.output_names, "u": model.input_names, "y": model.output_names, MANUAL: model.input_names}
        return names if "dv" not in self._signals or dv is None else {**names, "dv": dv.input_names}

    def _start_timers(self) -> None:
        for timer in self._own_timers:
            timer.cancel()
            self.destroy_timer(timer)
        wall = Clock(clock_type=ClockType.STEADY_TIME)
        settings = self.config.diagnostician
        self._own_timers = [
            self.create_timer(min(1.0, settings.stale_timeout_s / 4), self._check_silence, clock=wall),
            self.create_timer(settings.publish_period_s, self._republish, clock=wall),
        ]

    def on_configuration_changed(self, names: list[str]) -> None:
        """A new model or window applies from the next update; a new system restarts the window."""
        model = self.config.model
        al = self.aligner
        if al.sample_time_s != model.sample_time or al.channel_names != self._channel_names():
            self.aligner = self._new_aligner()
            self._warn("system channels or sample time changed: the window restarts")
        else:
            al.resize(self.config.diagnostician.window_samples)
            al.max_lag_samples = self.config.diagnostician.max_lag_samples
        self._start_timers()
        self.get_logger().info(f"parameters changed: {', '.join(names)}")

    def _on_active_model(self, msg: Any) -> None:
        """The controller switched models: take the new one, diagnose only the samples from its first on."""
        source = f"{self.resolve_topic_name(topic('active_model').name)} of the controller"
        try:
            active = read_active_model(msg.data, source)
        except ConfigError as exc:
            self._warn(f"ignored: {exc}")
            return
        if active.system == configured_system_tree(self.config.model, self.config.parameters):
            return
        flat = flatten_parameters({"system": active.system})
        result = self.set_parameters_atomically([Parameter(name, value=ros_value(v)) for name, v in flat.items()])
        if not result.successful:
            self._warn(f"the controller's model (revision {active.revision}) cannot be followed: {result.reason}")
            return
        self.model_since = active.first_sample
        self.get_logger().info(
            f"following the controller's model revision {active.revision} from sample {active.first_sample}"
        )

    # -- input ---------------------------------------------------------------
    def _warn(self, text: str) -> None:
        self.warnings.append(text)
        self.get_logger().warning(text)

    def _on_signal(self, signal: str, msg: Any) -> None:
        self.messages_received += 1
        self.silence.arrived(signal)
        stamp, names, values = read_signal(msg)
        self._check_publishers(signal, stamp, values)
        k, _ = sample_index(stamp, self.aligner.sample_time_s)
        if self._complete_at is not None and k > self._complete_at:
            self._complete_at, self.run_complete = None, False  # the run goes on after all: watch it again
        heard = self._heard[signal]
        self._heard[signal] = k if heard is None else max(k, heard)
        offer = offer_signal(
            self.aligner,
            signal,
            stamp_s=stamp,
            names=names,
            values=values,
            update_period_samples=self.config.diagnostician.update_period_samples,
            effort=msg.effort,
        )
        self.progress.took(signal, stamp_ns(msg.header.stamp))
        if heard is not None and k > heard + 1:
            self._count_lost(signal, heard + 1, k - 1)
        self._note_offer(offer)

    def _note_offer(self, offer: Offer) -> None:
        for text in [*offer.result.warnings, offer.newly_lagging]:
            if text:
                self._warn(text)
        if offer.newly_lagging or offer.update_due:
            self.publish_diagnostics()

    def _count_lost(self, signal: str, first: int, last: int) -> None:
        """Samples ``first..last`` of ``signal`` never arrived: count them and say where."""
        self.lost_samples[signal] += last - first + 1
        ts = self.aligner.sample_time_s
        self._warn(
            f"{self._labels[signal]}: {last - first + 1} sample(s) lost, stamps {first * ts:.9g}..{last * ts:.9g} s "
            f"({self.lost_samples[signal]} lost on this topic)"
        )

    def _check_publishers(self, signal: str, stamp_s: float, values: Any) -> None:
        """A repeated stamp with other values, or an older one, from a topic with two publishers: a conflict."""
        newest = self.aligner.newest[signal]
        k, _ = sample_index(stamp_s, self.aligner.sample_time_s)
        if newest is None or k > newest:
            return
        held = self.aligner.value(signal, k)
        if held is not None and held.shape == np.shape(values) and np.array_equal(held, values):
            return  # the same message again: harmless
        publishers = self.get_publishers_info_by_topic(self.resolve_topic_name(self._topics[signal]))
        if len(publishers) < 2:
            return  # one publisher going back in time: the aligner drops it with its own warning
        nodes = sorted({f"{p.node_namespace.rstrip('/')}/{p.node_name}" for p in publishers})
        kind = "other values for" if held is not None else "an older"
        reason = (
            f"{len(publishers)} publishers on {self._labels[signal]} ({', '.join(nodes)}) send different samples: "
            f"{kind} sample {k} (stamp {stamp_s:.9g} s) after sample {newest}; another node set without its own "
            "namespace, or a stray publisher? No verdict until none came for "
            f"{self.config.diagnostician.stale_timeout_s:g} s"
        )
        self.aligner.restart()
        first = self._active_conflict() is None
        self._conflict = (reason, time.monotonic())
        if first:
            self._warn(reason)
            self.publish_diagnostics()

    def _active_conflict(self) -> str | None:
        """The reason of a conflict still going on (or None; an ended one is forgotten)."""
        if self._conflict is None:
            return None
        reason, at = self._conflict
        if time.monotonic() - at < self.config.diagnostician.stale_timeout_s:
            return reason
        self._conflict = None
        self._warn("no conflicting sample for a while: the window restarted after the last one")
        return None

    def finish_run(self) -> None:
        """The run is over (its plant finished): the silence watchdog stops, no stale warning follows the run."""
        self.run_complete = True
        # a pause that a loaded machine made look like silence before the end: the verdicts are the last word
        self.worker.submit(self._end_silence)

    def _on_run_complete(self, msg: Any) -> None:
        """The producer published its last sample (contract topic ``run_complete``): the run's end, not a stop."""
        k, _ = sample_index(stamp_ns(msg.stamp) * 1e-9, self.aligner.sample_time_s)
        if not self.run_complete:
            self.get_logger().info(f"the run is complete after sample {k}: its silence from now on is no stale signal")
        self.finish_run()
        self._complete_at = k

    def _check_silence(self) -> None:
        if self.busy:
            self.silence.busy()
        if self.run_complete or self.busy:
            return
        found = self.silence.report(self.config.diagnostician.stale_timeout_s)
        if found is None:
            return
        reason, heard = found
        if heard:
            self._warn(reason)
        self._submit_without_verdict(reason, STALE_STATUS, silence=True)

    # -- output --------------------------------------------------------------
    def _submit_without_verdict(self, reason: str, state: str, *, silence: bool = False) -> None:
        out = without_verdict(state, reason, self.aligner, self.config, since=self.model_since)
        publish = self._publish_silence if silence else self._publish
        self.worker.submit(lambda: publish(out.diagnosis, out.window, out.stamp_s, state))

    def _publish_silence(self, diagnosis: Diagnosis, window: dict[str, int], stamp_s: float, state: str | None) -> None:
        """Publish the STALE statuses of a silence, remembering what they replace (for :meth:`finish_run`)."""
        before = self.last_published if self._silence is None else self._silence
        self._publish(diagnosis, window, stamp_s, state)
        self._silence = before

    def _end_silence(self) -> None:
        """The run was complete, not silent: the statuses a silence replaced are the last ones again."""
        if self._silence is not None:
            self.last_published, self._silence = self._silence, None
            self._diag_pub.publish(self.last_published)

    def _publish(self, diagnosis: Diagnosis, window: dict[str, int], stamp_s: float, state: str | None) -> None:
        """Publish the statuses of ``diagnosis`` (on the worker's thread, in submission order)."""
        name, prefix = self.config.model.name, status_prefix(self.config.model.name, self.get_namespace())
        statuses = diagnosis_statuses(diagnosis, prefix=prefix, hardware_id=name, window=window, state=state)
        msg = diagnostic_array(statuses, stamp_s)
        self.last_published, self._silence = msg, None
        self._diag_pub.publish(msg)

    def _diagnose(self, snapshot: SampleAligner, config: PmrConfig, since: int) -> None:
        """The worker's job: diagnose the window, close the loop on a verdict, publish it all (or why it failed)."""
        try:
            closed = close_window(evaluate_window(snapshot, config, since=since), config)
        except Exception as exc:  # the window says so, not the last verdicts; the next one is diagnosed anew
            closed = ClosedWindow(failed_window(snapshot, config, exc, since=since))
            self._job_failed(failure_reason(exc))
        self._publish_outcome(closed, config)

    def _publish_outcome(self, closed: ClosedWindow, config: PmrConfig) -> None:
        outcome = closed.outcome
        if closed.impact_note and closed.impact_note != self._impact_note:
            self._warn(closed.impact_note)  # once per cause, not every window
        self._impact_note = closed.impact_note or self._impact_note
        state = outcome.kind if outcome.kind in (STALE, FAILED) else None
        self._publish(outcome.diagnosis, outcome.window, outcome.stamp_s, state)
        if outcome.kind == VERDICT:
            self._estimates_pub.publish(estimates_message(outcome.diagnosis, outcome.stamp_s, config.model.name))
        if closed.proposal is not None:
            self.last_proposal = closed.proposal
            self._proposal_pub.publish(text_message("proposed_model", closed.proposal))

    def _republish(self) -> None:
        def again() -> None:
            if self.last_published is not None:
                self._diag_pub.publish(self.last_published)

        self.worker.submit(again)

    def _job_failed(self, text: str) -> None:
        self.get_logger().error(f"diagnosis failed: {text}")

    def publish_diagnostics(self) -> None:
        """Diagnose the current window (or say why not) and publish the statuses.

        The window is copied now; the diagnosis (:func:`pmr_ros.contract.windowing.evaluate_window`,
        shared with the offline diagnosis of a bag), its control impact and the
        proposal (:func:`pmr_ros.service.closing.close_window`) run on the
        worker thread, with the configuration and model switch of this moment.
        """
        conflict = self._active_conflict()
        if conflict is not None:
            self._submit_without_verdict(conflict, CONFLICT)
            return
        snapshot, config, since = self.aligner.snapshot(), self.config, self.model_since
        self.worker.submit(lambda: self._diagnose(snapshot, config, since))

    def wait_idle(self, timeout_s: float = 30.0) -> bool:
        """Block until every diagnosis due so far is published (tests); whether it was."""
        return self.worker.wait_idle(timeout_s)

    @property
    def busy(self) -> bool:
        """Whether a diagnosis is running or queued."""
        return self.worker.pending > 0

    def destroy_node(self) -> None:
        """Finish the running diagnosis (drop queued ones), stop the timers, destroy the node."""
        self.worker.shutdown()
        self.progress.destroy()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """Entry point of ``pmr_diagnostician``."""
    return run_node(PmrDiagnosticianNode, NODE_NAME, args)
