"""``mpc_controller``: constrained MPC on the model Ghat; u(k) from y(k) and r(k) (and the DVs v(k)).

The controller answers sample k once both y(k) and r(k) have arrived (in
either order; with measured disturbances, ``system.disturbance_names``, v(k)
on ``pmr/disturbance`` as well: fed forward), steps :class:`~pmr_ros.core.mpc.controller.LinearMpc` once per sample in
index order and publishes u(k) with the same stamp.  In real-time mode a late
setpoint is replaced by the newest earlier one.

Manual stretches (``run.manual_stretches``): the node plays the operator of
each MV whose controller is off, as the batch core does
(:class:`~pmr_ros.core.sim.operation.ManualOperator`): the MPC takes the
operator's value as a given input (it stops moving that MV), publishes it as
u(k), which the plant applies, and marks the MV in the message's ``effort``
(msg_defs/topics.yaml), from which the diagnostician learns the open loop.

A new model is accepted at runtime as one atomic change of the ``system``
parameters (``set_parameters_atomically``; the block is ``live`` for this node
in ``config/parameters.yaml``): validated like a params file, refused with the
reason in one line when invalid or of other channels or sample time (the
controller stays on its model), else its QP is built at once and it takes
over at the next sample without a bump (:meth:`~pmr_ros.core.mpc.controller.LinearMpc.take_over`).
The active model is published latched on ``pmr/active_model`` at start and at
every switch, stamped with the first sample it computes.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..config import ConfigError, PmrConfig
from ..contract.layout import read_signal
from ..contract.model_topics import active_model_text
from ..contract.samples import check_signal, sample_index
from ..contract.topics import topic
from ..core.mpc.controller import LinearMpc
from ..core.sim.excitation import dither_generator
from ..core.sim.operation import ManualOperator
from ..ros.base import ConfiguredNode, run_node
from ..ros.convert import signal_message, text_message
from ..service.memory_checks import check_controller_memory

NODE_NAME = "mpc_controller"


class MpcControllerNode(ConfiguredNode):
    """MPC in the loop over topics."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(kwargs.pop("node_name", NODE_NAME), executable=NODE_NAME, sim_time=True, **kwargs)
        self.model = self.config.model
        self.controller = LinearMpc(self.model, self.config.mpc, disturbance_model=self.config.disturbance_model)
        # the MV dither is a pure function of the sample and the seed, as in the batch core
        cfg = self.config
        self.dither = dither_generator(cfg.excitation, cfg.prbs, cfg.run.seed) if cfg.excitation.active else None
        self.operator = None
        if cfg.manual.active:
            limits = {"u_min": cfg.mpc.u_min, "u_max": cfg.mpc.u_max}
            self.operator = ManualOperator(cfg.manual, self.model.n_inputs, cfg.run.seed, **limits)
        self._applied = np.zeros(self.model.n_inputs)  # u(k - 1): where an operator's stretch starts from
        self.sample_time = self.model.sample_time
        self.next_sample = 0
        self._r: dict[int, np.ndarray] = {}
        self._y: dict[int, np.ndarray] = {}
        self._v: dict[int, np.ndarray] | None = None if self.config.disturbance_model is None else {}
        self._latest_v = np.zeros(
            0 if self.config.disturbance_model is None else self.config.disturbance_model.n_inputs
        )
        self._latest_r: np.ndarray | None = None
        self._labels = {
            "r": f"r on {topic('setpoint').name}",
            "y": f"y on {topic('measured_output').name}",
            "v": f"v on {topic('disturbance').name}",
        }
        self.revision = 0
        self._pending: LinearMpc | None = None
        self._model_pub = self.contract_publisher("active_model")
        self._publish_model(0)
        self._pub = self.contract_publisher("manipulated_input")
        self._r_sub = self.contract_subscription("setpoint", lambda msg: self._on_signal("r", msg))
        self._y_sub = self.contract_subscription("measured_output", lambda msg: self._on_signal("y", msg))
        if self._v is not None:
            self._v_sub = self.contract_subscription("disturbance", lambda msg: self._on_signal("v", msg))

    def check_start(self, config: PmrConfig) -> None:
        """A model the controller cannot be built on in memory is refused before it is built (one line, exit 2)."""
        check_controller_memory(config, self._source)

    def check_configuration(self, config: PmrConfig, names: list[str]) -> str | None:
        """A new model: its QP built now (refused if it cannot be), switched to at the next sample."""
        problem = self.controller.switch_problem(config.model)
        if problem:
            return problem
        try:
            check_controller_memory(config, "the new model")
        except ConfigError as exc:
            return str(exc)
        try:
            candidate = LinearMpc(config.model, self.controller.tuning, disturbance_model=config.disturbance_model)
        except (ValueError, np.linalg.LinAlgError) as exc:
            return f"the controller cannot be built on the new model: {exc}"
        self._pending = candidate
        return None

    def on_configuration_changed(self, names: list[str]) -> None:
        """The new model waits for the next sample boundary (see :meth:`_switch`)."""
        self.get_logger().info(f"new model accepted ({', '.join(names)}): switching at sample {self.next_sample}")

    def _switch(self, k: int) -> None:
        """Hand over to the pending controller before computing sample ``k``."""
        candidate, self._pending = self._pending, None
        if candidate is None:
            return
        candidate.take_over(self.controller)
        self.controller, self.model = candidate, candidate.model
        self.revision += 1
        self._publish_model(k)

    def _publish_model(self, first_sample: int) -> None:
        curves = str(self.config.parameters.get("system", {}).get("model_file", ""))
        text = active_model_text(self.model, first_sample=first_sample, revision=self.revision, model_file=curves)
        self._model_pub.publish(text_message("active_model", text))

    def _on_signal(self, signal: str, msg: Any) -> None:
        stamp, names, values = read_signal(msg)
        expected = self.model.output_names
        if signal == "v" and self.config.disturbance_model is not None:
            expected = self.config.disturbance_model.input_names
        problem = check_signal(self._labels[signal], names, values, expected)
        if problem:
            self.get_logger().warning(problem)
            return
        k, _ = sample_index(stamp, self.sample_time)
        if k < self.next_sample:
            return  # already answered (a duplicate or a late message)
        store = {"r": self._r, "y": self._y, "v": self._v}[signal]
        if store is None:
            return
        store[k] = values
        if signal == "v":
            self._latest_v = values
        if signal == "r":
            self._latest_r = values
        self._answer()

    def _answer(self) -> None:
        ready = sorted(k for k in self._y if k in self._r and (self._v is None or k in self._v))
        if not ready and not self.config.simulation.lockstep and self._y and self._latest_r is not None:
            k = min(self._y)
            self._r[k] = self._r.get(k, self._latest_r)  # real time: a late setpoint (or DV) is held
            ready = [k]
        for k in ready:
            if k < self.next_sample:
                continue
            if k > self.next_sample:
                self.get_logger().warning(
                    f"samples {self.next_sample}..{k - 1} never completed (r and y); continuing at sample {k}"
                )
            self._switch(k)
            dither = None if self.dither is None else self.dither.value(k)
            v = None if self._v is None else self._v.pop(k, self._latest_v)
            given = None if self.operator is None else self.operator.inputs(k, self._applied)
            u = self.controller.step(self._y.pop(k), self._r.pop(k), dither=dither, disturbance=v, manual_input=given)
            self._applied = u
            self.next_sample = k + 1
            manual = None if given is None else np.isfinite(given)
            stamp = k * self.sample_time
            self._pub.publish(signal_message(u, self.model.input_names, stamp, self.model.name, manual=manual))
        for store in (self._r, self._y, self._v or {}):
            for old in [j for j in store if j < self.next_sample]:
                del store[old]


def main(args: list[str] | None = None) -> int:
    """Entry point of ``mpc_controller``."""
    return run_node(MpcControllerNode, NODE_NAME, args)
