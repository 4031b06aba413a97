"""Checks of a closed-loop run that need no simulation: the model's memory and the samples its diagnosis needs.

Both are known from the configuration alone (:mod:`pmr_ros.core.sim.footprint`),
so a run that cannot succeed is refused in one line with the figure before a
state matrix is allocated or a minute is simulated.
"""

from __future__ import annotations

from . import check_memory

__all__ = ["check_model_memory", "model_memory", "not_run", "run_samples_shortfall"]


def model_memory(config) -> dict[str, int]:
    """What the plant's realization and the controller need [bytes], for :func:`~pmr_ros.commands.check_memory`."""
    from ..core.sim.footprint import model_bytes, states

    tuning = config.mpc
    needed = model_bytes(
        config.model,
        config.plant(),
        prediction_horizon=tuning.prediction_horizon,
        control_horizon=tuning.control_horizon,
    )
    return {f"plant and controller ({max(states(config.model), states(config.plant()))} states)": needed}


def check_model_memory(config) -> None:
    """Refuse a model or plant too large to build (its dense realization), naming its states and the figure.

    Raises
    ------
    CommandError
        One line: the states, the memory they need and what is available.
    """
    from ..core.sim.footprint import states

    counts = (states(config.model), states(config.plant()))
    n_out, n_in = config.model.n_outputs, config.model.n_inputs
    check_memory(
        model_memory(config),
        cause=(
            f"{config.source}: the {n_out}x{n_in} model has {counts[0]} states, the plant {counts[1]} (one per element "
            "and one per sample of each input's longest delay)"
        ),
        advice="use fewer elements or shorter delays",
    )


def run_samples_shortfall(config, *, samples: int) -> str | None:
    """Why ``samples`` are fewer than the diagnosis of ``config``'s model needs, or None when they suffice.

    Parameters
    ----------
    config : PmrConfig
    samples : int
        Samples the diagnosis will see (``run.samples``, at most the diagnostician's window).
    """
    from ..core.pmr.checks import segments_needed
    from ..core.pmr.diagnosis import method_welch
    from ..core.sim.footprint import planned_instruments, samples_needed

    model = config.model
    instruments = planned_instruments(config)
    welch = method_welch(samples, model=model, pmr=config.pmr, parametric=config.parametric, instruments=instruments)
    needed = samples_needed(model, welch, instruments=instruments)
    if samples >= needed:
        return None
    return (
        f"window too short, known before simulating: {samples} samples for a {model.n_outputs}x{model.n_inputs} "
        f"model; its diagnosis needs at least {needed} ({model.settling_samples()} of settling, then "
        f"{segments_needed(instruments)} Welch segments of {welch.segment_length} for {instruments} instruments): "
        f"give --samples {needed} or more"
    )


def not_run(config, reason: str) -> tuple:
    """The insufficient-data diagnosis and report of a run refused before simulating."""
    from ..core.results import Diagnosis
    from ..report import build_report

    diagnosis = Diagnosis.insufficient(
        method=config.pmr.method, models=config.model.element_models(), reason=reason, samples=config.run.samples
    )
    report = build_report(config, diagnosis, command="run", scenario=config.run.scenario, seed=config.run.seed)
    report["path"] = "not run"
    return diagnosis, report
