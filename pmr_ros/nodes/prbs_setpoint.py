"""``prbs_setpoint``: publishes the setpoints r(k) on every sample of the plant's clock.

The PRBS, or operator-like steps (``prbs.mode: steps``), on the setpoint CVs
only: a zone CV's setpoint stays at its nominal (``mpc.output_mode``).

The setpoint of sample k is a pure function of k (and the seed), so the node
needs no state but the last sample published: r(k) goes out as soon as the
plant's clock reaches k Ts.  It answers every clock sample but a repeat of the
last one, older ones included: a stray clock publisher ahead of the live plant
(an old bag replayed into the loop) must not silence the live loop's setpoints,
and a resumed plant's clock is answered at once.
"""

from __future__ import annotations

from typing import Any

from ..contract.layout import seconds_from_stamp
from ..contract.samples import sample_index
from ..core.sim.operation import setpoint_generator
from ..ros.base import ConfiguredNode, run_node
from ..ros.convert import signal_message

NODE_NAME = "prbs_setpoint"


class PrbsSetpointNode(ConfiguredNode):
    """Setpoint generator keyed on the plant's /clock."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(kwargs.pop("node_name", NODE_NAME), executable=NODE_NAME, sim_time=True, **kwargs)
        zones = self.config.mpc.zone_outputs
        moving = ~zones if zones.size else None
        self.generator = setpoint_generator(self.config.prbs, self.config.run.seed, moving=moving)
        self.names = self.config.model.output_names
        self.sample_time = self.config.model.sample_time
        self.sample = -1
        self._pub = self.contract_publisher("setpoint")
        self._clock_sub = self.contract_subscription("clock", self._on_clock)

    def _on_clock(self, msg: Any) -> None:
        stamp = seconds_from_stamp(msg.clock)
        k, _ = sample_index(stamp, self.sample_time)
        if k == self.sample:
            return  # the same clock sample again: r(k) is out already
        self.sample = k
        self._pub.publish(
            signal_message(self.generator.value(k), self.names, k * self.sample_time, self.config.model.name)
        )


def main(args: list[str] | None = None) -> int:
    """Entry point of ``prbs_setpoint``."""
    return run_node(PrbsSetpointNode, NODE_NAME, args)
