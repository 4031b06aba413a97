"""The four nodes in one process over real topics: the default path of ``pmr-ros run``.

The plant, setpoint generator, controller and diagnostician are ordinary nodes
of one rclpy Context and talk only over DDS topics; one executor spins them.
A listener node reads the diagnostician's verdicts from /diagnostics (and, on
request, records r, u and y from the wire).  Lockstep makes the run as fast as
the round trips allow and gives exactly the batch core's data.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from .config import PmrConfig, flatten_parameters, load_config
from .contract.layout import CONFLICT, FAILED, diagnosis_from_array, read_estimates, read_signal
from .contract.topics import DISTURBANCE_TOPIC, SIGNAL_TOPICS, topic
from .core.records import Record
from .core.results import Diagnosis
from .ros.flow import ProgressReporter, stamp_ns
from .ros.messages import message_class, qos_profile
from .ros.parameters import parameter_overrides
from .ros.run_watch import RunLimits, RunStalled, RunWatch
from .ros.signals import stop_requests

if TYPE_CHECKING:
    from .nodes.plant import PlantNode
    from .nodes.pmr_diagnostician import PmrDiagnosticianNode

DISCOVERY_VARIABLE = "ROS_AUTOMATIC_DISCOVERY_RANGE"

VERDICT_TIMEOUT_S = 180.0
"""How long a run may go without progress while the diagnostician diagnoses [s]: the final verdict comes
with its control impact (11 closed-loop simulations of 4,096 samples for a 3x3: 14-31 s at a load of 7;
on CI a final diagnosis under load outlasted the 30 s stall timeout)."""

_WATCHED_TOPICS = {**SIGNAL_TOPICS, "dv": DISTURBANCE_TOPIC}
"""Signal -> contract key of the topics a stall names."""


class NodeSetError(RuntimeError):
    """The node set did not finish (stalled, timed out, or its final diagnosis failed); the message says where."""


@dataclass
class NodeSetRun:
    """Outcome of an in-process node-set run.

    Attributes
    ----------
    config : PmrConfig
    diagnosis : Diagnosis
        Rebuilt from the final /diagnostics message.
    info : dict
        Levels and messages per element and the diagnosed window.
    estimates : dict or None
        The final estimates topic message (element -> quantity -> value).
    record : Record or None
        r, u, y as received from the topics (``record=True``), with ``manual`` from the modes marked on u.
    wall_time_s : float
        From the first published sample to the final verdicts.
    warnings : list of str
        What the diagnostician warned about.
    """

    config: PmrConfig
    diagnosis: Diagnosis
    info: dict
    estimates: dict | None
    record: Record | None
    wall_time_s: float
    warnings: list[str] = field(default_factory=list)

    @property
    def samples_per_second(self) -> float:
        """Closed-loop samples per second of wall time [samples/s]."""
        return self.config.run.samples / self.wall_time_s if self.wall_time_s > 0 else float("inf")


class _Listener(Node):
    """Reads /diagnostics and pmr/estimates of its namespace's set; records r, u, y by sample on request."""

    def __init__(self, context: Context, config: PmrConfig, record: bool, namespace: str = "/") -> None:
        super().__init__("pmr_run_listener", context=context, start_parameter_services=False, namespace=namespace)
        self.sample_time = config.model.sample_time
        self.final_sample = config.run.samples - 1
        self.final = None
        self.final_has_verdict = False
        self.conflict: str | None = None
        self.failure: str | None = None  # the final window's diagnosis failed: the run ends with this line
        self.estimates = None
        self.arrays: dict[str, np.ndarray] = {}
        self.counts: dict[str, int] = {}
        self.manual = np.zeros((0, config.model.n_inputs), dtype=bool)
        for key, callback in (("diagnostics", self._on_diagnostics), ("estimates", self._on_estimates)):
            t = topic(key)
            self.create_subscription(message_class(t), t.name, callback, qos_profile(t.qos))
        self.progress: ProgressReporter | None = None
        if record:
            # a consumer like the diagnostician: the plant never runs more than max_samples_ahead ahead of it
            self.progress = ProgressReporter(self, SIGNAL_TOPICS)
            n = config.run.samples
            widths = {"r": config.model.n_outputs, "u": config.model.n_inputs, "y": config.model.n_outputs}
            self.manual = np.zeros((n, config.model.n_inputs), dtype=bool)  # the modes marked on u
            for signal, key in SIGNAL_TOPICS.items():
                self.arrays[signal] = np.full((n, widths[signal]), np.nan)
                self.counts[signal] = 0
                t = topic(key)
                self.create_subscription(message_class(t), t.name, self._recorder(signal), qos_profile(t.qos))

    def _recorder(self, signal: str):
        def on_message(msg) -> None:
            stamp, _, values = read_signal(msg)
            if self.progress is not None:
                self.progress.took(signal, stamp_ns(msg.header.stamp))
            k = int(round(stamp / self.sample_time))
            if 0 <= k < self.arrays[signal].shape[0]:
                self.arrays[signal][k] = values
                self.counts[signal] += 1
                if signal == "u" and len(msg.effort) == values.size:
                    self.manual[k] = np.asarray(msg.effort) > 0.5

        return on_message

    def _on_diagnostics(self, msg) -> None:
        diagnosis, info = diagnosis_from_array(msg)
        status, final = info.get("status"), info.get("last_sample") == self.final_sample
        if status == CONFLICT:
            self.conflict = diagnosis.reason
        if final and status == FAILED:  # no verdict will come for the run's last window: no use waiting
            window = f"the final window (samples {info.get('first_sample', '?')}..{self.final_sample})"
            self.failure = f"the diagnosis of {window} failed: {diagnosis.reason}"
        elif final and status != CONFLICT:
            self.final = msg
            self.final_has_verdict = diagnosis.status == "ok"

    def _on_estimates(self, msg) -> None:
        stamp, _, _ = read_signal(msg)
        if int(round(stamp / self.sample_time)) == self.final_sample:
            self.estimates = msg

    def recorded(self) -> dict[str, int]:
        """Signal -> samples recorded (empty without recording)."""
        return dict(self.counts)

    @property
    def done(self) -> bool:
        recorded = all(c >= self.final_sample + 1 for c in self.counts.values())
        estimated = self.final is not None and (self.estimates is not None or not self.final_has_verdict)
        return estimated and recorded


def node_parameter_values(config: PmrConfig) -> dict[str, Any]:
    """The dotted parameter values every node of the set gets: the effective configuration.

    With a ``plant`` block the ``mismatch`` block and ``run.scenario`` are left out: they do not
    apply, and a node given both refuses them (as a params file giving both is refused).
    """
    flat = flatten_parameters(config.parameters)
    if config.explicit_plant is not None:
        flat = {k: v for k, v in flat.items() if not k.startswith("mismatch.") and k != "run.scenario"}
    return flat


def build_nodes(config: PmrConfig, context: Context, extra: dict | None = None, namespace: str = "/") -> list[Node]:
    """The four nodes on ``context`` in ``namespace``, all with the full parameter set of ``config``.

    ``extra`` holds dotted parameter values laid over the configuration.
    """
    from .nodes.mpc_controller import MpcControllerNode
    from .nodes.plant import PlantNode
    from .nodes.pmr_diagnostician import PmrDiagnosticianNode
    from .nodes.prbs_setpoint import PrbsSetpointNode

    flat = node_parameter_values(config)
    flat.update(extra or {})
    params = parameter_overrides(flat)
    nodes: list[Node] = []
    try:
        for cls in (PmrDiagnosticianNode, MpcControllerNode, PrbsSetpointNode, PlantNode):
            nodes.append(cls(context=context, parameter_overrides=params, namespace=namespace))
    except Exception:
        for node in nodes:
            node.destroy_node()
        raise
    return nodes


@dataclass(frozen=True)
class NodeSetOptions:
    """How :func:`run_node_set` runs the node set.

    Attributes
    ----------
    domain_id : int, optional
        ROS domain of the private Context (default: ``ROS_DOMAIN_ID`` or 0).
    record : bool
        Also record r, u and y from the topics.
    diagnose_once : bool
        Set the diagnostician's window, update period and minimum to the run
        length, so it diagnoses once, the whole run, like the batch path.
    stall_timeout_s : float
        Give up when the run goes this long without progress toward its end [s]: no new sample of
        the plant, none taken by the diagnostician or recorded, no final verdicts (:mod:`pmr_ros.ros.run_watch`).
    verdict_timeout_s : float
        ... or this long while the diagnostician diagnoses [s] (:data:`VERDICT_TIMEOUT_S`).
    extra_parameters : dict, optional
        Dotted parameter values for every node (after ``diagnose_once``).
    executor_kind : str
        One of :data:`EXECUTORS`.
    private : bool
        Discovery off: the nodes see only each other, no other process sees
        them (and concurrent runs cannot disturb each other).
    extra_nodes : callable, optional
        ``extra_nodes(context, parameters)`` builds nodes spun with the set
        (e.g. a bag recorder); ``parameters`` are the dotted values every node
        got.  The run also waits for each one's ``done`` (when it has one).
    namespace : str
        The node set's namespace: every topic of the contract is relative, so
        several sets share a domain (``/`` by default).
    """

    domain_id: int | None = None
    record: bool = False
    diagnose_once: bool = True
    stall_timeout_s: float = 30.0
    verdict_timeout_s: float = VERDICT_TIMEOUT_S
    extra_parameters: dict[str, Any] | None = None
    executor_kind: str = "events"
    private: bool = False
    extra_nodes: Callable[[Context, dict[str, Any]], list[Node]] | None = None
    namespace: str = "/"

    def parameters(self, config: PmrConfig) -> dict[str, Any]:
        """The dotted parameter values laid over the configuration for every node."""
        n = config.run.samples
        extra: dict[str, Any] = {}
        if self.diagnose_once:
            keys = ("diagnostician.window_samples", "diagnostician.update_period_samples", "diagnostician.min_samples")
            extra.update(dict.fromkeys(keys, n))
        if self.private:
            extra["simulation.discovery_settle_s"] = 0.0  # discovery is off: there is no one to wait for
        extra.update(self.extra_parameters or {})
        return extra


def _spin_until_done(executor: Any, nodes: list[Node], listener: _Listener, watch: RunWatch, stop: list[int]) -> None:
    while not (listener.done and all(getattr(node, "done", True) for node in nodes)):
        executor.spin_once(timeout_sec=0.05)
        if stop:
            raise KeyboardInterrupt
        if listener.conflict is not None:
            raise NodeSetError(f"the diagnostician reports a conflict: {listener.conflict}")
        # a node that cannot go on (a recorder on a full disk; the listener when the final window's diagnosis
        # failed) ends the run with its one-line reason
        failure = next((f for node in nodes if (f := getattr(node, "failure", None))), None)
        if failure:
            raise NodeSetError(failure)
        try:
            watch.check()
        except RunStalled as exc:
            raise NodeSetError(str(exc)) from None


def _watch(plant: PlantNode, diagnostician: Any, listener: _Listener, nodes: list[Node], options: NodeSetOptions):
    """The run's bounded watch, with the plant's own pace and start-up bound (its parameters, overrides applied)."""
    limits = RunLimits(
        samples=plant.samples,
        stall_timeout_s=options.stall_timeout_s,
        verdict_timeout_s=options.verdict_timeout_s,
        start_timeout_s=plant.start_bound_s,
        real_time_rate_hz=plant.config.simulation.real_time_rate_hz,
    )
    labels = {s: f"{s} on {listener.resolve_topic_name(topic(key).name)}" for s, key in _WATCHED_TOPICS.items()}
    labels.update({key: listener.resolve_topic_name(topic(key).name) for key in ("diagnostics", "estimates")})
    others = [n for n in nodes if n not in (plant, diagnostician, listener) and hasattr(n, "done")]
    return RunWatch(plant, diagnostician, listener, limits, labels=labels, others=others)


def run_node_set(config: PmrConfig | None = None, options: NodeSetOptions | None = None) -> NodeSetRun:
    """Run the four nodes in this process for ``config.run.samples`` samples in lockstep.

    Parameters
    ----------
    config : PmrConfig, optional
        Default: the shipped Wood-Berry configuration.
    options : NodeSetOptions, optional
        Domain, recording, executor, extra nodes (defaults: see :class:`NodeSetOptions`).

    Raises
    ------
    NodeSetError
        When the run stalls or overruns its bounds (one line naming the node or topic and the sample), or the
        diagnosis of its final window failed (one line naming the exception).
    """
    config = config or load_config()
    options = options or NodeSetOptions()
    extra = options.parameters(config)
    context = Context()
    _init_context(context, options.domain_id, options.private)
    nodes: list[Node] = []
    executor = None
    with stop_requests() as stop:
        try:
            nodes = build_nodes(config, context, extra, options.namespace)
            # build_nodes' order: the diagnostician first, the plant last
            diagnostician, plant = cast("PmrDiagnosticianNode", nodes[0]), cast("PlantNode", nodes[-1])
            listener = _Listener(context, config, options.record, options.namespace)
            nodes.append(listener)
            if options.extra_nodes is not None:
                nodes.extend(options.extra_nodes(context, {**flatten_parameters(config.parameters), **extra}))
            executor = make_executor(options.executor_kind, context)
            for node in nodes:
                executor.add_node(node)
            watch = _watch(plant, diagnostician, listener, nodes, options)
            _spin_until_done(executor, nodes, listener, watch, stop)
            diagnosis, info = diagnosis_from_array(listener.final, diagnostician.get_name())
            record_out = _recorded(listener) if options.record else None
            estimates = read_estimates(listener.estimates) if listener.estimates is not None else None
            return NodeSetRun(
                config, diagnosis, info, estimates, record_out, watch.wall_time_s, list(diagnostician.warnings)
            )
        finally:
            if executor is not None:
                executor.shutdown(timeout_sec=1.0)
            for node in nodes:
                node.destroy_node()
            rclpy.try_shutdown(context=context)


def _recorded(listener: _Listener) -> Record:
    """r, u, y as the listener received them, with the modes marked on u (``manual``, when any MV was off)."""
    arrays = listener.arrays
    manual = listener.manual if listener.manual.any() else None
    return Record(arrays["r"], arrays["u"], arrays["y"], manual=manual)


def _init_context(context: Context, domain_id: int | None, private: bool) -> None:
    """``rclpy.init`` of ``context``; ``private`` turns discovery off for this Context only.

    rcl reads ``ROS_AUTOMATIC_DISCOVERY_RANGE`` when a context starts, so the
    variable is set just around the call.
    """
    if not private:
        rclpy.init(context=context, domain_id=domain_id)
        return
    before = os.environ.get(DISCOVERY_VARIABLE)
    os.environ[DISCOVERY_VARIABLE] = "OFF"
    try:
        rclpy.init(context=context, domain_id=domain_id)
    finally:
        if before is None:
            del os.environ[DISCOVERY_VARIABLE]
        else:
            os.environ[DISCOVERY_VARIABLE] = before


EXECUTORS = ("events", "single")
"""``events``: rclpy's EventsExecutor (about 3x faster here); ``single``: SingleThreadedExecutor."""


def make_executor(kind: str, context: Context):
    """An executor of ``kind`` (see :data:`EXECUTORS`) on ``context``."""
    if kind == "events":
        from rclpy.experimental import EventsExecutor

        # EventsExecutor calls faulthandler.enable() on sys.stderr, which fails when
        # stderr is not a real file (captured output): give it the process's stderr.
        stderr = sys.stderr
        try:
            stderr.fileno()
        except (AttributeError, OSError, ValueError):
            sys.stderr = sys.__stderr__
        try:
            return EventsExecutor(context=context)
        finally:
            sys.stderr = stderr
    if kind == "single":
        return SingleThreadedExecutor(context=context)
    raise ValueError(f"executor {kind!r}: must be one of {', '.join(EXECUTORS)}")
