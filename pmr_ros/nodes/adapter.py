"""The live model update of ``pmr-ros run --adapt``: apply the diagnostician's proposal, judge it, roll it back.

An ordinary node of the node set, talking only over the contract and the
controller's parameter services: it waits for the diagnostician's first
verdict window (the "before" window, diagnosed against the model the
controller started with), takes the proposal published for that window on
``pmr/proposed_model``, hands its ``system`` block to ``mpc_controller`` as one
atomic parameter change (the ``set_parameters_atomically`` service), learns
the switch sample from ``pmr/active_model``, waits for the first verdict
window wholly after the switch (the "after" window, diagnosed against the new
model) and judges the update (:func:`pmr_ros.core.loop.adaptation.judge_update`:
a larger mismatch, or a tracking error risen beyond
``adapt.ise_rise_tolerance_pct``).  A worse update is rolled back the same way,
to the previous model.  The tracking figures come from r, u and y as heard on
their topics; like every reader of them it is a lockstep consumer (it reports
its progress on ``pmr/progress``), so the plant never outruns it.  It lives in
the node set's namespace: its topics and the controller's parameter services
resolve there.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient

from ..config import ConfigError, PmrConfig, flatten_parameters, parse_config
from ..contract.layout import diagnosis_from_array, read_signal
from ..contract.model_topics import read_active_model, system_parameters
from ..contract.samples import sample_index
from ..contract.topics import SIGNAL_TOPICS, topic
from ..core.loop.adaptation import Adaptation, TrackingFigures, judge_update, tracking_figures
from ..core.results import Diagnosis
from ..ros.flow import ProgressReporter, stamp_ns
from ..ros.messages import message_class, qos_profile
from ..ros.parameters import ros_value

__all__ = ["ModelAdapter"]

CONTROLLER = "mpc_controller"
DIAGNOSTICIAN = "pmr_diagnostician"
WINDOW_IN_PROPOSAL = re.compile(r"\(samples (\d+)\.\.(\d+)\)")


@dataclass
class _Window:
    diagnosis: Diagnosis
    first: int
    last: int


class ModelAdapter(Node):
    """Applies the diagnostician's proposal to the controller once, judges it, rolls it back if worse.

    Parameters
    ----------
    context : rclpy Context
    config : PmrConfig
        The run's configuration (the controller's first model, the MPC's weights, ``adapt``).
    proposal_filter : callable, optional
        ``proposal_filter(system_block) -> system_block`` applied to the
        proposed ``system`` block before it is sent (tests: a deliberately
        wrong proposal).
    namespace : str
        The node set's namespace (``/`` by default).

    Attributes
    ----------
    before, after : _Window or None
        The verdict windows before and after the update.
    adaptation : Adaptation or None
        The outcome, once judged.
    notes : list of str
        What happened that the report should say (a refused proposal, no mismatch).
    """

    def __init__(
        self,
        context: Any,
        config: PmrConfig,
        *,
        proposal_filter: Callable[[dict], dict] | None = None,
        namespace: str = "/",
    ) -> None:
        super().__init__("pmr_adapter", context=context, start_parameter_services=False, namespace=namespace)
        self.config = config
        self.proposal_filter = proposal_filter
        self.before: _Window | None = None
        self.after: _Window | None = None
        self.adaptation: Adaptation | None = None
        self.notes: list[str] = []
        self.models: list[tuple[int, dict]] = []  # (first sample, system block) per revision
        self._proposals: dict[tuple[int, int], str] = {}
        self._request: Any = None
        self._sent: str | None = None  # "update" or "rollback" while a change is pending
        self._finished = False
        n = config.run.samples
        widths = {"r": config.model.n_outputs, "u": config.model.n_inputs, "y": config.model.n_outputs}
        self.arrays = {s: np.full((n, widths[s]), np.nan) for s in widths}
        self._client = AsyncParameterClient(self, CONTROLLER)
        for key, callback in (
            ("diagnostics", self._on_diagnostics),
            ("proposed_model", self._on_proposal),
            ("active_model", self._on_active_model),
        ):
            t = topic(key)
            self.create_subscription(message_class(t), t.name, callback, qos_profile(t.qos))
        self.progress = ProgressReporter(self, SIGNAL_TOPICS)
        for signal, key in SIGNAL_TOPICS.items():
            t = topic(key)
            self.create_subscription(message_class(t), t.name, self._recorder(signal), qos_profile(t.qos))
        self._timer = self.create_timer(0.02, self._step, clock=Clock(clock_type=ClockType.STEADY_TIME))

    # -- what is heard ------------------------------------------------------
    def _recorder(self, signal: str) -> Callable[[Any], None]:
        def on_message(msg: Any) -> None:
            stamp, _, values = read_signal(msg)
            self.progress.took(signal, stamp_ns(msg.header.stamp))
            k, _ = sample_index(stamp, self.config.model.sample_time)
            if 0 <= k < self.arrays[signal].shape[0] and values.shape == self.arrays[signal][k].shape:
                self.arrays[signal][k] = values

        return on_message

    def _on_diagnostics(self, msg: Any) -> None:
        diagnosis, info = diagnosis_from_array(msg, DIAGNOSTICIAN)
        if diagnosis.status != "ok" or "first_sample" not in info:
            return
        window = _Window(diagnosis, int(info["first_sample"]), int(info["last_sample"]))
        if self.before is None:
            self.before = window
        elif self.after is None and self.switch_sample is not None and window.first >= self.switch_sample:
            self.after = window

    def _on_proposal(self, msg: Any) -> None:
        found = WINDOW_IN_PROPOSAL.search(msg.data)
        if found:
            self._proposals[(int(found.group(1)), int(found.group(2)))] = msg.data

    def _on_active_model(self, msg: Any) -> None:
        try:
            active = read_active_model(msg.data, self.resolve_topic_name(topic("active_model").name))
        except ConfigError as exc:
            self.notes.append(f"ignored: {exc}")
            return
        if active.revision == len(self.models):
            self.models.append((active.first_sample, active.system))

    @property
    def switch_sample(self) -> int | None:
        """The first sample of the updated model, once the controller switched."""
        return self.models[1][0] if len(self.models) > 1 else None

    @property
    def done(self) -> bool:
        """Nothing left to do: judged (and rolled back if worse), or nothing to update, or refused."""
        return self._finished

    # -- what is done -------------------------------------------------------
    def _step(self) -> None:
        if self._finished or self._waiting():
            return
        if self.before is None or not self.models:
            return
        if self._sent is None and len(self.models) == 1:
            self._propose()
        elif self.after is not None and self.adaptation is None:
            self._judge()
        elif self.adaptation is not None and (not self.adaptation.judgement.worse or len(self.models) > 2):
            self._finish()

    def _waiting(self) -> bool:
        """A parameter change is on its way: take its answer when it is there."""
        if self._request is None:
            return False
        if not self._request.done():
            return True
        answer, kind = self._request.result(), self._sent
        self._request = None
        if not answer.result.successful:
            self.notes.append(f"the controller refused the {kind}: {answer.result.reason}")
            self._finished = True
        return False

    def _propose(self) -> None:
        assert self.before is not None
        if not any(e.verdict == "mismatch" for e in self.before.diagnosis):
            self.notes.append("no mismatch verdict in the first window: nothing to update")
            self._finished = True
            return
        text = self._proposals.get((self.before.first, self.before.last))
        if text is None:
            return  # the proposal follows its statuses
        try:
            system = system_parameters(text, self.resolve_topic_name(topic("proposed_model").name))
        except ConfigError as exc:
            self.notes.append(f"the proposal could not be read: {exc}")
            self._finished = True
            return
        block = {key.split(".", 1)[1]: value for key, value in system.items()}
        if self.proposal_filter is not None:
            block = self.proposal_filter(block)
        self._send("update", block)

    def _send(self, kind: str, block: dict) -> None:
        if not self._client.services_are_ready():
            return  # asked again on the next tick
        flat = flatten_parameters({"system": block})
        self._sent = kind
        self._request = self._client.set_parameters_atomically(
            [Parameter(name, value=ros_value(value)) for name, value in flat.items()]
        )

    def _tracking(self, window: _Window) -> TrackingFigures:
        span = slice(window.first, window.last + 1)
        r, u, y = (self.arrays[s][span] for s in ("r", "u", "y"))
        heard = np.all(np.isfinite(r), axis=1) & np.all(np.isfinite(u), axis=1) & np.all(np.isfinite(y), axis=1)
        mpc = self.config.mpc
        return tracking_figures(
            r[heard],
            u[heard],
            y[heard],
            output_weight=mpc.output_weight,
            move_weight=mpc.move_weight,
            first_sample=window.first,
        )

    def _judge(self) -> None:
        assert self.before is not None and self.after is not None and self.switch_sample is not None
        tracking = (self._tracking(self.before), self._tracking(self.after))
        judgement = judge_update(
            self.before.diagnosis, self.after.diagnosis, tracking=tracking, settings=self.config.adapt
        )
        old, new = self.models[0][1], self.models[1][1]
        changes = _changes(old, new)
        self.adaptation = Adaptation(self.before.diagnosis, changes, self.switch_sample, tracking, judgement)
        if judgement.worse:
            self._send("rollback", dict(old))

    def _finish(self) -> None:
        assert self.adaptation is not None
        if len(self.models) > 2:
            self.adaptation = replace(self.adaptation, rolled_back=True, rollback_sample=self.models[2][0])
        self._finished = True
        self._timer.cancel()


def _changes(old: dict, new: dict) -> tuple:
    """The elements whose model the update changed: (name, model before, model after)."""
    models = [parse_config({"system": system}, "active model").model.element_models() for system in (old, new)]
    return tuple(
        (name, models[0][name][2], models[1][name][2]) for name in models[0] if models[0][name][2] != models[1][name][2]
    )
