"""``wood_berry_plant`` (node ``plant``): the true plant G; steps on u, publishes y and drives /clock.

Lockstep (``simulation.real_time_rate_hz: 0``, the default): the plant
publishes /clock = k Ts and then y(k), and steps only when u(k) arrives, so a
run is as fast as the machine allows and gives the same data as the batch
core.  Real time (> 0): a wall timer samples at that rate and holds the last
input if u(k) is late.  Any n x n system from the parameters, with the
mismatch of ``run.scenario`` applied.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import numpy as np
from rclpy.clock import Clock, ClockType

from ..contract.alignment import check_signal, sample_index
from ..contract.layout import read_signal
from ..contract.topics import topic
from ..core.plant import FoptdPlant
from ..ros.base import ConfiguredNode, run_node
from ..ros.convert import clock_message, signal_message

if TYPE_CHECKING:
    from rclpy.timer import Timer

EXECUTABLE = "wood_berry_plant"
"""The executable's name: what users type, kept from the reference case though it runs any system."""
NODE_NAME = "plant"


class PlantNode(ConfiguredNode):
    """Steps :class:`~pmr_ros.core.plant.FoptdPlant` from u messages and publishes y and /clock.

    Attributes
    ----------
    sample : int
        Index k of the newest published y(k).
    finished : bool
        True after ``run.samples`` samples.
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(kwargs.pop("node_name", NODE_NAME), executable=EXECUTABLE, sim_time=True, **kwargs)
        cfg = self.config
        self.model = cfg.plant()
        self.plant = FoptdPlant(self.model, cfg.noise_std, cfg.run.seed, disturbance=cfg.disturbance)
        self.samples = cfg.run.samples
        self.sample_time = cfg.model.sample_time
        self.sample = -1
        self.finished = False
        self._u_label = f"u on {topic('manipulated_input').name}"
        self._u_received: dict[int, np.ndarray] = {}
        self._u_held = np.zeros(self.model.n_inputs)
        self._clock_pub = self.contract_publisher("clock")
        self._y_pub = self.contract_publisher("measured_output")
        self._u_sub = self.contract_subscription("manipulated_input", self._on_input)
        self._started_at = time.monotonic()
        wall = Clock(clock_type=ClockType.STEADY_TIME)
        self._start_timer = self.create_timer(0.01, self._try_start, clock=wall)
        self._tick_timer: Timer | None = None
        mode = (
            "lockstep"
            if self.config.simulation.lockstep
            else f"real time at {self.config.simulation.real_time_rate_hz:g} samples/s"
        )
        self.get_logger().info(
            f"{self.model.name or 'plant'}: scenario {cfg.run.scenario}, {self.samples} samples, {mode}"
        )

    def _try_start(self) -> None:
        waited = time.monotonic() - self._started_at
        ready = (
            self._y_pub.get_subscription_count() >= self.config.simulation.wait_for_subscribers
            and self.count_publishers(topic("manipulated_input").name) >= 1
        )
        if not ready and waited < self.config.simulation.startup_timeout_s:
            return
        if not ready:
            self.get_logger().warning(
                f"starting after {waited:.1f} s without the expected peers: {self._y_pub.get_subscription_count()} "
                "subscribers of y "
                f"(want {self.config.simulation.wait_for_subscribers}), "
                f"{self.count_publishers(topic('manipulated_input').name)} publishers of u"
            )
        self._start_timer.cancel()
        self.destroy_timer(self._start_timer)
        if self.config.simulation.lockstep:
            self._publish_sample(0)
        else:
            wall = Clock(clock_type=ClockType.STEADY_TIME)
            self._tick_timer = self.create_timer(
                1.0 / self.config.simulation.real_time_rate_hz, self._on_tick, clock=wall
            )

    def _publish_sample(self, k: int) -> None:
        """Publish /clock = k Ts, then the measurement y(k)."""
        self.sample = k
        stamp = k * self.sample_time
        self._clock_pub.publish(clock_message(stamp))
        self._y_pub.publish(signal_message(self.plant.measure(), self.model.output_names, stamp, self.model.name))

    def _advance(self, u: np.ndarray) -> None:
        """Hold u(k) over sample k, then publish sample k + 1 (or finish)."""
        self.plant.advance(u)
        self._u_held = u
        if self.sample + 1 >= self.samples:
            self.finished = True
            self.get_logger().info(f"run complete: {self.samples} samples")
            if self._tick_timer is not None:
                self._tick_timer.cancel()
            return
        self._publish_sample(self.sample + 1)

    def _on_input(self, msg) -> None:
        stamp, names, values = read_signal(msg)
        problem = check_signal(self._u_label, names, values, self.model.input_names)
        if problem:
            self.get_logger().warning(problem)
            return
        k, _ = sample_index(stamp, self.sample_time)
        if self.finished or k < self.sample:
            return
        if not self.config.simulation.lockstep:
            self._u_received[k] = values
            return
        if k != self.sample:
            self.get_logger().warning(f"{self._u_label}: input for sample {k} while at sample {self.sample}; ignored")
            return
        self._advance(values)

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


def main(args: list[str] | None = None) -> int:
    """Entry point of ``wood_berry_plant``."""
    return run_node(PlantNode, EXECUTABLE, args)
