"""What a node or the control impact builds, checked against the memory available before any of it is allocated.

``pmr-ros run`` checks its plant and controller first
(:mod:`pmr_ros.commands.preflight`); a node started on its own, or the
control impact of ``pmr-ros diagnose``, did not: a plant delay of 10^6
samples died in an ``ArrayMemoryError`` traceback (a 7 TB state matrix) and a
200x200 model was killed by the kernel.  The states and bytes come from
:mod:`pmr_ros.core.sim.footprint`; a node is refused with a
:class:`~pmr_ros.config.ConfigError` (its entry point prints the one line and
exits with 2), the control impact is skipped with the reason in one line.
"""

from __future__ import annotations

from ..config import ConfigError, PmrConfig
from ..core.sim.footprint import controller_bytes, impact_bytes, realization_bytes, states
from ..core.sim.memory import memory_shortfall
from ..core.sim.model import TransferMatrix

__all__ = ["STATES", "check_controller_memory", "check_impact_memory", "check_plant_memory", "impact_shortfall"]

STATES = "one per element and one per sample of each input's longest delay"
"""What the states of a realization are, for the messages."""

SMALLER = "use fewer elements or shorter delays"


def _refuse(source: str, field: str, what: str, parts: dict[str, int], advice: str = SMALLER) -> None:
    problem = memory_shortfall(parts)
    if problem is not None:
        raise ConfigError(source, field, None, f"{what}: {problem}: {advice}")


def _shape(model: TransferMatrix) -> str:
    return f"{model.n_outputs}x{model.n_inputs}"


def check_plant_memory(config: PmrConfig, source: str) -> None:
    """Refuse a simulated plant whose realization does not fit (the plant node, before it builds it).

    Raises
    ------
    ConfigError
        Naming the plant's shape, states and the memory they need.
    """
    plant = config.plant()
    block = (
        "the plant block" if config.explicit_plant is not None else f"the model with run.scenario {config.run.scenario}"
    )
    _refuse(
        source,
        "plant",
        f"the simulated {_shape(plant)} plant ({block}) has {states(plant)} states ({STATES})",
        {"realization": realization_bytes(plant)},
    )


def check_controller_memory(config: PmrConfig, source: str) -> None:
    """Refuse a model the MPC cannot be built on in the memory available (the controller node).

    Raises
    ------
    ConfigError
        Naming the model's shape, states and the memory they need.
    """
    model, tuning = config.model, config.mpc
    needed = controller_bytes(
        model, prediction_horizon=tuning.prediction_horizon, control_horizon=tuning.control_horizon
    )
    _refuse(
        source,
        "system",
        f"the {_shape(model)} model has {states(model)} states ({STATES})",
        {"controller": needed},
    )


def _impact_problem(config: PmrConfig, plant: TransferMatrix) -> str | None:
    tuning = config.mpc
    needed = impact_bytes(
        config.model,
        plant,
        prediction_horizon=tuning.prediction_horizon,
        control_horizon=tuning.control_horizon,
        samples=config.impact.samples,
    )
    return memory_shortfall({"MPC and plant simulation": needed})


def impact_shortfall(config: PmrConfig, plant: TransferMatrix) -> str | None:
    """Why the control impact on ``plant`` (the model as estimated) cannot be simulated, in one line; else None."""
    problem = _impact_problem(config, plant)
    if problem is None:
        return None
    model = config.model
    return (
        f"control impact not computed: the MPC on the {_shape(model)} model ({states(model)} states) steering the "
        f"estimated plant ({states(plant)} states) {problem}"
    )


def check_impact_memory(config: PmrConfig, source: str) -> None:
    """Refuse a diagnostician whose control impact (the MPC on the model, simulated) could never fit.

    Nothing is checked with ``impact.samples`` 0 (no impact) or a controller other than the MPC
    (``controller.kind`` pi simulates a few PI loops, external nothing).

    Raises
    ------
    ConfigError
        Naming ``impact.samples``, the model's states and the figure.
    """
    if not config.impact.active or config.controller.kind != "mpc":
        return
    model = config.model
    problem = _impact_problem(config, model)
    if problem is not None:
        raise ConfigError(
            source,
            "impact.samples",
            config.impact.samples,
            f"the control impact simulates the MPC on the {_shape(model)} model ({states(model)} states, {STATES}): "
            f"{problem}: set impact.samples to 0 to diagnose without it, or {SMALLER}",
        )
