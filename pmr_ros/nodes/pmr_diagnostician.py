"""``pmr_diagnostician``: PMR verdicts per element on /diagnostics from r, u and y alone.

It subscribes to the setpoints, inputs and outputs and to nothing else, holds
the controller's model Ghat as parameters (so it can watch any controller),
aligns the three signals by their sample stamps, keeps a rolling window of the
newest unbroken stretch and diagnoses it with :func:`pmr_ros.core.diagnosis.diagnose`
every ``diagnostician.update_period_samples`` samples.  One DiagnosticStatus
per element goes to /diagnostics (OK / WARN / ERROR, or STALE / WARN with the
reason and no numbers when the data do not support a verdict); the numbers
also go to the estimates topic when there is a verdict.

With a verdict it closes the loop (:mod:`pmr_ros.contract.proposal`): the
control impact of the mismatches goes into the statuses (each element's
``impact.*``, all together ``impact_all.*``), and when a mismatch verdict
stands the corrected model is published, latched, on ``pmr/proposed_model``.
It follows the controller's model: a new one on ``pmr/active_model`` becomes
its own (the same validated parameter change as ``set_parameters``) and only
samples from the switch on are diagnosed against it.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from typing import Any

from rclpy.clock import Clock, ClockType
from rclpy.parameter import Parameter

from ..config import ConfigError, flatten_parameters
from ..config.write import system_tree
from ..contract.alignment import SIGNALS, SampleAligner
from ..contract.layout import STALE as STALE_STATUS
from ..contract.layout import read_signal
from ..contract.model_topics import read_active_model
from ..contract.proposal import close_diagnosis, model_file_text
from ..contract.topics import SIGNAL_TOPICS, topic
from ..contract.windowing import STALE, VERDICT, check_window_memory, evaluate_window, offer_signal, window_info
from ..core.results import Diagnosis
from ..ros.base import ConfiguredNode, run_node
from ..ros.convert import diagnosis_statuses, diagnostic_array, estimates_message, text_message
from ..ros.parameters import ros_value

NODE_NAME = "pmr_diagnostician"


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
    model_since : int
        The first sample the controller ran on the current model (0 until a switch).
    last_proposal : str or None
        The newest proposed model published.
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(kwargs.pop("node_name", NODE_NAME), executable=NODE_NAME, live_parameters=True, **kwargs)
        check_window_memory(self.config, f"parameters of node {self.get_fully_qualified_name()}")
        self.warnings: deque[str] = deque(maxlen=1000)
        self.last_published = None
        self.messages_received = 0
        self._labels = {s: f"{s} on {topic(SIGNAL_TOPICS[s]).name}" for s in SIGNALS}
        self.aligner = self._new_aligner()
        self._last_arrival: dict[str, float | None] = {s: None for s in SIGNALS}
        self._created = time.monotonic()
        self._stale_reported: float | None = None
        self.model_since = 0
        self.last_proposal: str | None = None
        self._diag_pub = self.contract_publisher("diagnostics")
        self._estimates_pub = self.contract_publisher("estimates")
        self._proposal_pub = self.contract_publisher("proposed_model")
        self._model_sub = self.contract_subscription("active_model", self._on_active_model)
        self._subs = [self.contract_subscription(SIGNAL_TOPICS[s], self._callback(s)) for s in SIGNALS]
        wall = Clock(clock_type=ClockType.STEADY_TIME)
        self._stale_timer = self.create_timer(self._stale_check_period(), self._check_silence, clock=wall)

    # -- set-up --------------------------------------------------------------
    def _new_aligner(self) -> SampleAligner:
        model = self.config.model
        names = {"r": model.output_names, "u": model.input_names, "y": model.output_names}
        return SampleAligner(
            model.sample_time,
            names,
            self._labels,
            self.config.diagnostician.window_samples,
            self.config.diagnostician.max_lag_samples,
        )

    def _stale_check_period(self) -> float:
        return min(1.0, self.config.diagnostician.stale_timeout_s / 4)

    def on_configuration_changed(self, names: list[str]) -> None:
        """A new model or window applies from the next update; a new system restarts the window."""
        model = self.config.model
        al = self.aligner
        if al.sample_time_s != model.sample_time or al.channel_names != {
            "r": model.output_names,
            "u": model.input_names,
            "y": model.output_names,
        }:
            self.aligner = self._new_aligner()
            self._warn("system channels or sample time changed: the window restarts")
        else:
            al.resize(self.config.diagnostician.window_samples)
            al.max_lag_samples = self.config.diagnostician.max_lag_samples
        self._stale_timer.cancel()
        self.destroy_timer(self._stale_timer)
        self._stale_timer = self.create_timer(
            self._stale_check_period(), self._check_silence, clock=Clock(clock_type=ClockType.STEADY_TIME)
        )
        self.get_logger().info(f"parameters changed: {', '.join(names)}")

    def _on_active_model(self, msg: Any) -> None:
        """The controller switched models: take the new one, diagnose only the samples from its first on."""
        source = f"{topic('active_model').name} of the controller"
        try:
            active = read_active_model(msg.data, source)
        except ConfigError as exc:
            self._warn(f"ignored: {exc}")
            return
        if active.system == system_tree(self.config.model):
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
    def _callback(self, signal: str) -> Callable[[Any], None]:
        def on_message(msg: Any) -> None:
            self._on_signal(signal, msg)

        return on_message

    def _warn(self, text: str) -> None:
        self.warnings.append(text)
        self.get_logger().warning(text)

    def _on_signal(self, signal: str, msg: Any) -> None:
        self.messages_received += 1
        self._last_arrival[signal] = time.monotonic()
        stamp, names, values = read_signal(msg)
        period = self.config.diagnostician.update_period_samples
        offer = offer_signal(
            self.aligner, signal, stamp_s=stamp, names=names, values=values, update_period_samples=period
        )
        for text in offer.result.warnings:
            self._warn(text)
        if offer.newly_lagging:
            self._warn(offer.newly_lagging)
            self.publish_diagnostics()
        if offer.update_due:
            self.publish_diagnostics()

    def _check_silence(self) -> None:
        now = time.monotonic()
        limit = self.config.diagnostician.stale_timeout_s
        silent = [s for s in SIGNALS if (now - (self._last_arrival[s] or self._created)) > limit]
        if not silent:
            self._stale_reported = None
            return
        if self._stale_reported is not None and now - self._stale_reported < limit:
            return
        self._stale_reported = now
        never = [s for s in silent if self._last_arrival[s] is None]
        parts = [f"no {self._labels[s]} for {now - (self._last_arrival[s] or self._created):.1f} s" for s in silent]
        reason = "; ".join(parts) if len(never) < len(SIGNALS) else f"no data received in {now - self._created:.1f} s"
        if len(never) < len(SIGNALS):
            self._warn(reason)
        window = self._window_info()
        silent_diagnosis = Diagnosis.insufficient(
            method=self.config.pmr.method,
            models=self.config.model.element_models(),
            reason=reason,
            samples=int(window.get("window_samples", 0)),
        )
        self._publish(silent_diagnosis, window, STALE_STATUS)

    # -- output --------------------------------------------------------------
    def _window_info(self) -> dict[str, int]:
        return window_info(self.aligner, self.config.diagnostician.window_samples)

    def _publish(self, diagnosis: Diagnosis, window: dict[str, int], state: str | None = None) -> None:
        al = self.aligner
        newest = al.stretch_last if al.stretch_last is not None else 0
        model = self.config.model
        statuses = diagnosis_statuses(
            diagnosis, node_name=self.get_name(), hardware_id=model.name, window=window, state=state
        )
        msg = diagnostic_array(statuses, newest * al.sample_time_s)
        self.last_published = msg
        self._diag_pub.publish(msg)

    def publish_diagnostics(self) -> None:
        """Diagnose the current window (or say why not) and publish the statuses.

        The decision and the diagnosis are :func:`pmr_ros.contract.windowing.evaluate_window`,
        which the offline diagnosis of a bag shares.
        """
        config = self.config
        outcome = evaluate_window(self.aligner, config, since=self.model_since)
        if outcome.kind != VERDICT:
            self._publish(outcome.diagnosis, outcome.window, STALE_STATUS if outcome.kind == STALE else None)
            return
        closed = close_diagnosis(outcome.diagnosis, config)
        self._publish(closed.diagnosis, outcome.window)
        self._estimates_pub.publish(estimates_message(closed.diagnosis, outcome.stamp_s, config.model.name))
        if closed.proposes and closed.update is not None:
            self.last_proposal = model_file_text(config, closed.update, closed.diagnosis, window=outcome.window)
            self._proposal_pub.publish(text_message("proposed_model", self.last_proposal))


def main(args: list[str] | None = None) -> int:
    """Entry point of ``pmr_diagnostician``."""
    return run_node(PmrDiagnosticianNode, NODE_NAME, args)
