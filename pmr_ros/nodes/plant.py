"""``wood_berry_plant`` (node ``plant``): the true plant G; steps on u, publishes y and drives the clock.

Lockstep (``simulation.real_time_rate_hz: 0``, the default): the plant
publishes the clock k Ts and then y(k), and steps only when u(k) arrives, so a
run is as fast as the machine allows and gives the same data as the batch
core.  It also waits for every lockstep consumer (the publishers of
``pmr/progress``: the diagnostician, a recorder) to be at most
``simulation.max_samples_ahead`` samples behind (:mod:`pmr_ros.ros.flow`), so
none of them ever loses a sample.  Real time (> 0): a wall timer samples at
that rate and holds the last input if u(k) is late; it cannot wait, and the
diagnostician counts what its consumers lose.

A plant started while the others already hold a run (it crashed and was
restarted) resumes that run: it takes the controller's newest input u(k) from
the topic's history (or as soon as one for a later sample arrives; while the
consumers report samples taken it waits for it, :data:`RESUME_WAIT_S`), holds it
and goes on with sample k + 2.  Its simulated state starts again at rest; the
sample it leaves out is a break every consumer sees in the stamps, so the
diagnostician's window (and the offline diagnosis of a bag) restarts after it
(msg_defs/README.md, "Restarts").
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import numpy as np
from rclpy.clock import Clock, ClockType

from ..contract.layout import read_signal
from ..contract.samples import check_signal, sample_index
from ..contract.topics import topic
from ..core.sim.augment import augmented_model
from ..core.sim.true_plant import FoptdPlant
from ..ros.base import ConfiguredNode, run_node
from ..ros.convert import clock_message, run_complete_message, signal_message, stamp_from_seconds
from ..ros.flow import ProgressGate, stamp_ns
from ..service.memory_checks import check_plant_memory

if TYPE_CHECKING:
    from rclpy.timer import Timer

    from ..config import PmrConfig

EXECUTABLE = "wood_berry_plant"
"""The executable's name: what users type, kept from the reference case though it runs any system."""
NODE_NAME = "plant"

RESUME_SETTLE_S = 0.5
"""After its peers are there, how long the plant listens for the controller's newest input before
sample 0 (a restarted plant resumes after it) [s of wall time]; generous, as a busy machine delivers
the controller's history late."""

CONSUMER_DISCOVERY_S = 15.0
"""How long the plant waits, once its peers are there, for each other subscriber of y to be known as a
consumer of the flow control before it starts anyway [s of wall time].  The wait ends as soon as every
subscriber is known, so only a subscriber that never reports (a plotter) costs it.  DDS discovers a
node's endpoints one by one, later on a loaded machine; a consumer whose progress writer is found after
the plant started is not held for, so the plant may run more than the topics' history (1000 samples)
ahead of it and its window loses the start (the suspected cause of a run under two busy loops whose
verdicts missed the full window; 2 s left little margin)."""

RESUME_WAIT_S = 30.0
"""How long after its peers are there a plant waits for the controller's newest input when a consumer
reports samples taken: a run is under way, and a restarted plant must resume it, not start it over
[s of wall time].  The input comes from the controller's topic history, which a loaded machine delivers
late (seen after the 3 s discovery settle plus :data:`RESUME_SETTLE_S`: the plant started over from
sample 0).  Only a consumer left over from an earlier run, with a new controller that has sent nothing,
costs a plant the whole wait; it then starts from sample 0 with a warning."""

RESUME_QUIET_S = 0.5
"""Inputs for later samples are gathered until none came for this long, then the plant resumes
after the newest (the history of a topic arrives as a burst) [s of wall time].  At 0.05 s, at a load
of 8 on the 2 cores, a pause inside the burst made a plant resume at sample 642 of 1202."""


class PlantNode(ConfiguredNode):
    """Steps :class:`~pmr_ros.core.sim.true_plant.FoptdPlant` from u messages and publishes y and the clock.

    Attributes
    ----------
    sample : int
        Index k of the newest published y(k).
    finished : bool
        True after ``run.samples`` samples.
    resumed_at : list of int
        The first sample published after each resumption of a run the others held.
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(kwargs.pop("node_name", NODE_NAME), executable=EXECUTABLE, sim_time=True, **kwargs)
        cfg = self.config
        self.model = cfg.plant()
        dv_plant = cfg.disturbance_plant() if cfg.disturbance_model is not None else None
        whole = self.model if dv_plant is None else augmented_model(self.model, dv_plant)
        self.plant = FoptdPlant(whole, cfg.noise_std, cfg.run.seed, disturbance=cfg.disturbance)
        # the measured disturbances: a pure function of the sample and the seed, as in the batch core
        self.dv = None if dv_plant is None else cfg.disturbance_signal.generator(cfg.run.seed)
        self._dv_now = np.zeros(0)
        self.samples = cfg.run.samples
        self.sample_time = cfg.model.sample_time
        self.sample = -1
        self.finished = False
        self.resumed_at: list[int] = []
        self._u_topic = topic("manipulated_input").name
        self._u_label = f"u on {self.resolve_topic_name(self._u_topic)}"
        self._u_received: dict[int, np.ndarray] = {}
        self._u_held = np.zeros(self.model.n_inputs)
        self._ahead: tuple[int, np.ndarray] | None = None
        self._ahead_at = 0.0
        self._next: int | None = None
        self._clock_pub = self.contract_publisher("clock")
        self._y_pub = self.contract_publisher("measured_output")
        self._dv_pub = self.contract_publisher("disturbance") if self.dv is not None else None
        self._end_pub = self.contract_publisher("run_complete")
        self.gate = ProgressGate(self, max_ahead=cfg.simulation.max_samples_ahead, on_change=self._release)
        self._u_sub = self.contract_subscription("manipulated_input", self._on_input)
        self._started_at = time.monotonic()
        self._peers_at: float | None = None
        self._ready_at: float | None = None
        self._waiting_noted = False
        wall = Clock(clock_type=ClockType.STEADY_TIME)
        self._start_timer = self.create_timer(0.01, self._try_start, clock=wall)
        self._resume_timer = self.create_timer(RESUME_QUIET_S / 2, self._resume_if_quiet, clock=wall)
        self._tick_timer: Timer | None = None
        self.get_logger().info(
            f"{self.model.name or 'plant'}: scenario {cfg.run.scenario}, {self.samples} samples, {self._mode()}"
        )

    def check_start(self, config: PmrConfig) -> None:
        """A plant whose realization cannot fit in memory is refused before it is built (one line, exit 2)."""
        check_plant_memory(config, self._source)

    @property
    def start_bound_s(self) -> float:
        """The longest this plant waits before its first sample [s of wall time].

        For its peers, then for the consumers it does not know yet, then (a run under way) for the controller's
        input to resume after.
        """
        sim = self.config.simulation
        waits = CONSUMER_DISCOVERY_S + RESUME_SETTLE_S + RESUME_WAIT_S
        return max(sim.discovery_settle_s, sim.startup_timeout_s) + waits

    def _mode(self) -> str:
        sim = self.config.simulation
        if sim.lockstep:
            return f"lockstep, at most {sim.max_samples_ahead} samples ahead of its consumers"
        return f"real time at {sim.real_time_rate_hz:g} samples/s"

    # -- start -----------------------------------------------------------------
    def _peers_ready(self) -> bool:
        """The controller and ``simulation.wait_for_subscribers`` subscribers of y are there, and matched.

        Matched, not only in the graph: the controller's kept inputs and the consumers' kept reports, which tell a
        restarted plant where the run is, reach it only once its subscriptions matched their writers (in the graph
        but not matched yet under load, a restarted plant started the run over from sample 0).
        """
        return (
            self._y_pub.get_subscription_count() >= self.config.simulation.wait_for_subscribers
            and self._u_sub.get_publisher_count() >= 1
            and self.gate.matched()
        )

    def _unknown_subscribers(self) -> list[str]:
        """Subscribers of y that are neither the controller nor a consumer the flow control knows."""
        controllers = {
            f"{i.node_namespace.rstrip('/')}/{i.node_name}"
            for i in self.get_publishers_info_by_topic(self.resolve_topic_name(self._u_topic))
        }
        return self.gate.silent_subscribers([topic("measured_output").name], exclude=controllers)

    def _check_ready(self, now: float) -> None:
        """Note when the peers are there (or the start-up timeout passed), with a warning for what is missing.

        Nothing is decided before ``simulation.discovery_settle_s`` from the
        plant's start: DDS needs that long to discover the nodes already running.
        Once the controller and enough subscribers are there, the plant also
        waits up to :data:`CONSUMER_DISCOVERY_S` for each other subscriber of y
        to be known as a consumer (DDS discovers a node's endpoints one by one),
        so none is outrun before it reports; a subscriber that never reports (a
        plotter) is named and not waited for.
        """
        sim = self.config.simulation
        waited = now - self._started_at
        if waited < sim.discovery_settle_s:
            return  # nodes running before this one (a recorder) may not be discovered yet: they would lose the start
        if self._peers_at is None and self._peers_ready():
            self._peers_at = now
        unknown = self._unknown_subscribers() if self._peers_at is not None else []
        if self._peers_at is not None and (not unknown or now - self._peers_at >= CONSUMER_DISCOVERY_S):
            self._ready_at = now
            consumers = ", ".join(self.gate.consumers()) or "none"
            self.get_logger().info(f"starting after {waited:.1f} s; consumers of the flow control: {consumers}")
            if unknown:
                self.get_logger().warning(
                    f"subscribers of y that report no progress, not waited for (they may miss samples): "
                    f"{', '.join(unknown)}"
                )
        elif waited >= sim.startup_timeout_s:
            self._ready_at = now
            self.get_logger().warning(
                f"starting after {waited:.1f} s without the expected peers: {self._y_pub.get_subscription_count()} "
                f"subscribers of y (want {sim.wait_for_subscribers}), {self.count_publishers(self._u_topic)} "
                "publishers of u"
            )

    def _try_start(self) -> None:
        now = time.monotonic()
        if self._ready_at is None:
            self._check_ready(now)
        if self._ready_at is None or now - self._ready_at < RESUME_SETTLE_S or self._ahead is not None:
            return  # the controller's newest input may still be on its way: a restarted plant resumes after it
        if self._run_under_way(now):
            return
        self._start_timer.cancel()
        self.destroy_timer(self._start_timer)
        if self.sample >= 0:
            return  # resumed already
        if self.config.simulation.lockstep:
            self._schedule(0)
        else:
            wall = Clock(clock_type=ClockType.STEADY_TIME)
            self._tick_timer = self.create_timer(
                1.0 / self.config.simulation.real_time_rate_hz, self._on_tick, clock=wall
            )

    def _run_under_way(self, now: float) -> bool:
        """Whether consumers report samples taken and the controller's input to resume after is not here yet.

        Waits so for at most :data:`RESUME_WAIT_S` after the peers are there (lockstep only: in real time a
        plant does not resume).
        """
        if self.sample >= 0 or not self.config.simulation.lockstep or self._ready_at is None:
            return False
        taken = {name: ns for name, ns in self.gate.consumers().items() if ns is not None}
        if not taken:
            return False
        newest = max(taken.values()) * 1e-9
        if now - self._ready_at < RESUME_WAIT_S:
            if not self._waiting_noted:
                self._waiting_noted = True
                self.get_logger().info(
                    f"a run is under way ({', '.join(taken)} took the sample stamped {newest:.9g} s): waiting for "
                    f"the controller's newest input to resume after it"
                )
            return True
        self.get_logger().warning(
            f"consumers report the sample stamped {newest:.9g} s taken, but no input of the controller came "
            f"within {RESUME_WAIT_S:g} s: starting the run from sample 0"
        )
        return False

    # -- publishing --------------------------------------------------------------
    def _schedule(self, k: int) -> None:
        """Publish sample k as soon as the consumers allow (lockstep) or now (real time)."""
        self._next = k
        self._release()

    def _release(self) -> None:
        if self._next is None or (self.config.simulation.lockstep and not self.gate.open()):
            return
        k, self._next = self._next, None
        self._publish_sample(k)

    def _publish_sample(self, k: int) -> None:
        """Publish the clock k Ts, the measured disturbances v(k) (when there are DVs), then the measurement y(k)."""
        self.sample = k
        stamp = k * self.sample_time
        self._clock_pub.publish(clock_message(stamp))
        if self.dv is not None and self._dv_pub is not None:
            self._dv_now = self.dv.value(k)
            names = self.config.disturbance_model.input_names if self.config.disturbance_model else ()
            self._dv_pub.publish(signal_message(self._dv_now, names, stamp, self.model.name))
        self._y_pub.publish(signal_message(self.plant.measure(), self.model.output_names, stamp, self.model.name))
        self.gate.published(stamp_ns(stamp_from_seconds(stamp)))

    def _advance(self, u: np.ndarray) -> None:
        """Hold u(k) (and v(k)) over sample k, then publish sample k + 1 (or finish)."""
        self.plant.advance(u if self.dv is None else np.concatenate((u, self._dv_now)))
        self._u_held = u
        if self.sample + 1 >= self.samples:
            self.finished = True
            self.get_logger().info(f"run complete: {self.samples} samples")
            # the consumers in other processes learn that the silence from now on is the run's end
            self._end_pub.publish(run_complete_message(self.sample * self.sample_time, self.model.name))
            if self._tick_timer is not None:
                self._tick_timer.cancel()
            return
        if self.config.simulation.lockstep:
            self._schedule(self.sample + 1)
        else:
            self._publish_sample(self.sample + 1)

    # -- input ---------------------------------------------------------------------
    def _on_input(self, msg: Any) -> None:
        stamp, names, values = read_signal(msg)
        problem = check_signal(self._u_label, names, values, self.model.input_names)
        if problem:
            self.get_logger().warning(problem)
            return
        k, _ = sample_index(stamp, self.sample_time)
        if self.finished or k < self.sample or (k == self.sample and self._next is not None):
            return  # an input already applied, or a stray publisher's old stamp
        if not self.config.simulation.lockstep:
            self._u_received[k] = values
            return
        if k > self.sample or self.sample < 0:
            self._note_ahead(k, values)
            return
        self._advance(values)

    def _note_ahead(self, k: int, values: np.ndarray) -> None:
        """An input for a sample this plant has not published: the others hold a run it should resume."""
        publishers = self.count_publishers(self._u_topic)
        if publishers > 1:
            self.get_logger().warning(
                f"{self._u_label}: input for sample {k} while at sample {self.sample}, from one of {publishers} "
                "publishers of u (another controller, or a node set without its own namespace?); ignored",
                throttle_duration_sec=5.0,
            )
            return
        if self._ahead is None or k > self._ahead[0]:
            self._ahead = (k, values)
        self._ahead_at = time.monotonic()

    def _resume_if_quiet(self) -> None:
        if self._ahead is None or time.monotonic() - self._ahead_at < RESUME_QUIET_S or self.finished:
            return
        if self._ready_at is None:
            return  # resume, like start, once the controller and the consumers are there
        k, u = self._ahead
        self._ahead = None
        if k < self.sample or (k == self.sample and self._next is not None):
            return  # the loop went past it meanwhile
        if k > self.sample:
            # sample k + 1 is left out: the break in the stamps restarts every consumer's window (the diagnostician's
            # and, from a bag, the offline one's alike) where the simulated state starts again at rest
            self.get_logger().warning(
                f"resuming the run after sample {k}, which the controller already answered (a restarted plant?): "
                f"sample {k + 1} is left out, so the consumers' windows restart at sample {k + 2}"
            )
            self.resumed_at.append(k + 2)
            self._next = None
            self.gate.reset()
            self.sample = k + 1
        self._advance(u)

    def _on_tick(self) -> None:
        if self.sample < 0:
            self._publish_sample(0)
            return
        u = self._u_received.pop(self.sample, None)
        if u is None:
            self.get_logger().warning(
                f"{self._u_label}: u({self.sample}) late; holding the previous input", throttle_duration_sec=5.0
            )
            u = self._u_held
        self._u_received = {k: v for k, v in self._u_received.items() if k > self.sample}
        self._advance(u)

    def destroy_node(self) -> None:
        """Stop the flow-control timer, then destroy the node."""
        self.gate.destroy()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """Entry point of ``wood_berry_plant``."""
    return run_node(PlantNode, EXECUTABLE, args)
