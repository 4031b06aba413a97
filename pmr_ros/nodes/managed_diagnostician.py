"""The diagnostician as a managed (lifecycle) node: configure validates, activate subscribes, deactivate stops.

``pmr_diagnostician_lifecycle`` holds the diagnostician's declared
parameters (:mod:`pmr_ros.nodes.pmr_diagnostician`) and moves through the
``rclpy.lifecycle`` states a launch file or ``ros2 lifecycle set`` drives:

- *configure* validates the parameters into a configuration (as a params
  file would be); a bad one fails the transition, its one-line reason logged
  and kept in :attr:`ManagedDiagnosticianNode.refusal`;
- *activate* starts the diagnostician itself, named ``pmr_diagnostician``
  (so its /diagnostics statuses and every reader of them stay as they are),
  in the same executor: it subscribes to r, u and y and publishes verdicts;
- *deactivate* destroys it: no subscription, no publication, no timer is left;
- *cleanup* forgets the configuration.

Each transition is logged in one line.  Started as a program
(``pmr_diagnostician_lifecycle --ros-args --params-file config/wood_berry.yaml``)
it waits, unconfigured, for ``ros2 lifecycle set /pmr_diagnostician_lifecycle configure``
(then ``activate``), as a launch file's ``LifecycleNode`` does.
"""

from __future__ import annotations

from typing import Any

from rcl_interfaces.msg import SetParametersResult
from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn

from ..config import ConfigError, PmrConfig, parse_config
from ..config.files import nested
from ..ros.base import run_node
from ..ros.parameters import descriptor, node_parameters, parameter_overrides, plain_value, ros_value
from .pmr_diagnostician import NODE_NAME, PmrDiagnosticianNode

__all__ = ["LIFECYCLE_NODE_NAME", "ManagedDiagnosticianNode", "main"]

LIFECYCLE_NODE_NAME = "pmr_diagnostician_lifecycle"
"""The managed node's name; the diagnostician it starts keeps ``pmr_diagnostician``."""


class ManagedDiagnosticianNode(LifecycleNode):
    """The lifecycle wrapper of :class:`PmrDiagnosticianNode` (see the module).

    Parameters
    ----------
    **kwargs
        Passed to :class:`rclpy.lifecycle.LifecycleNode` (``context``, ``parameter_overrides``, ``namespace``).

    Attributes
    ----------
    config : PmrConfig or None
        The configuration of the last successful *configure*.
    diagnostician : PmrDiagnosticianNode or None
        The running diagnostician while active.
    refusal : str
        Why the last *configure* failed ("" when it did not).
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(kwargs.pop("node_name", LIFECYCLE_NODE_NAME), **kwargs)
        self._source = f"parameters of node {self.get_fully_qualified_name()}"
        self._names: list[str] = []
        for spec in node_parameters(NODE_NAME):
            value = None if spec.required else ros_value(spec.default)
            if value is None:
                self.declare_parameter(spec.name, descriptor=descriptor(spec, read_only=False))
            else:
                self.declare_parameter(spec.name, value, descriptor(spec, read_only=False))
            self._names.append(spec.name)
        self.config: PmrConfig | None = None
        self.diagnostician: PmrDiagnosticianNode | None = None
        self.refusal = ""
        self._flat: dict[str, Any] = {}
        self._changed: set[str] = set()
        self.add_on_set_parameters_callback(self._note_changes)

    def _note_changes(self, changes: list[Any]) -> SetParametersResult:
        """Parameters set after the start count as given at the next *configure* (checked there)."""
        self._changed.update(p.name for p in changes if p.name in self._names)
        return SetParametersResult(successful=True)

    def _given(self) -> dict[str, Any]:
        """What was given at start or set since, as a params file would give it; the declared defaults fill the rest."""
        given = {*self._parameter_overrides, *self._changed} & set(self._names)
        values = {p.name: plain_value(p.value) for p in self.get_parameters(sorted(given))}
        return {name: value for name, value in values.items() if value is not None}

    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Validate the parameters; a bad configuration fails the transition with its reason."""
        flat = self._given()
        try:
            self.config = parse_config(nested(flat), self._source)
        except ConfigError as exc:
            self.refusal = str(exc)
            self.get_logger().error(f"configure failed: {exc}")
            return TransitionCallbackReturn.FAILURE
        self._flat, self.refusal = flat, ""
        model = self.config.model
        self.get_logger().info(
            f"configured: {model.name or 'system'}, {model.n_outputs}x{model.n_inputs}, {self.config.pmr.method} PMR"
        )
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Start the diagnostician (subscriptions, verdicts) in this node's executor."""
        try:
            self.diagnostician = PmrDiagnosticianNode(
                context=self.context,
                namespace=self.get_namespace(),
                parameter_overrides=parameter_overrides(self._flat),
            )
        except ConfigError as exc:
            self.get_logger().error(f"activate failed: {exc}")
            return TransitionCallbackReturn.FAILURE
        if self.executor is not None:
            self.executor.add_node(self.diagnostician)
        self.get_logger().info(f"activated: {self.diagnostician.get_fully_qualified_name()} subscribes to r, u, y")
        return super().on_activate(state)

    def _stop(self) -> None:
        if self.diagnostician is None:
            return
        if self.executor is not None:
            self.executor.remove_node(self.diagnostician)
        self.diagnostician.destroy_node()
        self.diagnostician = None

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Stop the diagnostician: no subscription, no publication is left."""
        self._stop()
        self.get_logger().info("deactivated: the diagnostician stopped (no subscriptions, no verdicts)")
        return super().on_deactivate(state)

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Forget the configuration."""
        self.config, self._flat = None, {}
        self.get_logger().info("cleaned up: the configuration is forgotten")
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Stop the diagnostician if it runs."""
        self._stop()
        self.get_logger().info("shut down")
        return TransitionCallbackReturn.SUCCESS

    def destroy_node(self) -> None:
        """Stop the diagnostician if it runs (Ctrl-C in the active state), then destroy this node."""
        self._stop()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """Entry point of ``pmr_diagnostician_lifecycle``."""
    return run_node(ManagedDiagnosticianNode, LIFECYCLE_NODE_NAME, args)
