"""After a verdict: the control impact of the mismatches and the corrected model proposed to the controller.

Shared, rclpy-free, by ``pmr-ros run``/``diagnose`` (``--write-model``, the
impact in the report: :func:`close_and_write`) and the live ``pmr_diagnostician`` (the impact on
/diagnostics, the proposal on ``pmr/proposed_model``: :func:`close_window`, run
on its worker thread with the window's diagnosis), so the same diagnosis gives
the same impact figures and the same params file everywhere.
"""

from __future__ import annotations

import hashlib
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..config import PmrConfig
from ..config.write import curve_file_path, model_params_text, write_curve_file, write_params_file
from ..contract.windowing import VERDICT, WindowOutcome
from ..core.loop.impact import Mapper, control_impact
from ..core.loop.update import ModelUpdate, NotCorrectable, corrected_model
from ..core.results import Diagnosis
from ..core.sim.augment import augmented_model
from .memory_checks import impact_shortfall
from .refusal import EXIT_INSUFFICIENT, ServiceError

__all__ = [
    "Closed",
    "ClosedWindow",
    "close_and_write",
    "close_diagnosis",
    "close_window",
    "curve_file",
    "external_note",
    "model_file_text",
]


@dataclass(frozen=True)
class Closed:
    """A diagnosis with its control impact, and the corrected model it gives.

    Attributes
    ----------
    diagnosis : Diagnosis
        With :attr:`~pmr_ros.core.results.Diagnosis.impact` and each mismatched
        element's impact when computed (``impact.samples`` > 0 and a mismatch).
    update : ModelUpdate or None
        The corrected model; None when the diagnosis cannot give one.
    why_not : str
        Why there is no corrected model ("" when there is).
    impact_note : str
        Why the control impact was not computed although a mismatch stands (the
        simulation would not fit in memory), in one line; "" otherwise.
    """

    diagnosis: Diagnosis
    update: ModelUpdate | None
    why_not: str = ""
    impact_note: str = ""

    @property
    def proposes(self) -> bool:
        """Whether a mismatch verdict stands, so the corrected model differs from the controller's."""
        return self.update is not None and bool(self.update.changes)


def close_diagnosis(diagnosis: Diagnosis, config: PmrConfig, *, jobs: int = 1) -> Closed:
    """The control impact of ``diagnosis``'s mismatches and the corrected model.

    Parameters
    ----------
    diagnosis : Diagnosis
        Verdicts on the controller's model ``config.model``.
    config : PmrConfig
        The controller's model and tuning, the excitation and ``impact.samples``.
    jobs : int
        Worker processes for the impact's closed-loop simulations (one per mismatched element, and two more);
        1: one after another in this process.

    Returns
    -------
    Closed
        A diagnosis that has its impact already (the live diagnostician's, read
        from /diagnostics) keeps it.  The impact is skipped, with
        :attr:`Closed.impact_note` saying why, when its simulation of the MPC on
        the estimated plant would not fit in memory (checked before allocating)
        or the controller is ``external`` (:func:`external_note`).  Kind ``pi``
        simulates the configured PI loops instead of the MPC.
    """
    try:
        update = corrected_model(config.model, diagnosis, disturbance_model=config.disturbance_model)
    except NotCorrectable as exc:
        return Closed(diagnosis, None, str(exc))
    if config.impact.active and update.changes and diagnosis.impact is None:  # (read from /diagnostics: has it)
        controller = config.controller
        if controller.kind == "external":
            return Closed(diagnosis, update, impact_note=external_note(config))
        skipped = impact_shortfall(config, update.model) if controller.kind == "mpc" else None
        if skipped is not None:
            return Closed(diagnosis, update, impact_note=skipped)
        diagnosis = control_impact(
            diagnosis,
            loop=config,
            update=update,
            samples=config.impact.samples,
            controller=controller,
            mapper=_on_workers(jobs) if jobs > 1 else None,
        )
    return Closed(diagnosis, update)


def _on_workers(jobs: int) -> Mapper:
    """A mapper that runs its tasks on up to ``jobs`` local worker processes, results in the tasks' order."""

    def mapper(work: Callable[[Any], Any], tasks: Sequence[Any]) -> list[Any]:
        from concurrent.futures.process import BrokenProcessPool

        from ..core.sim.workers import worker_pool

        try:
            with worker_pool(min(jobs, len(tasks))) as pool:
                return list(pool.map(work, tasks))
        except BrokenProcessPool:
            raise ServiceError(
                "control impact: a worker process ended before its simulation was done (killed? out of memory?)"
            ) from None

    return mapper


def external_note(config: PmrConfig) -> str:
    """Why the control impact is not computed under ``controller.kind: external``, in one line."""
    return config.controller.why_external or (
        "control impact not computed: controller.kind external (the plant's controller is not simulated; "
        "controller.kind pi with the loops' tuning, or mpc, computes it)"
    )


def _verdict_lines(diagnosis: Diagnosis) -> list[str]:
    return [f"verdict {e.name}: {e.verdict} - {e.summary()}" for e in diagnosis]


def curve_file(config: PmrConfig, update: ModelUpdate, model_path: str | None = None) -> str:
    """``system.model_file`` of the corrected model, its curves written: '' without step_response elements.

    With ``model_path`` (``--write-model``) the curves go beside that params
    file, in the format of the configuration's curve file, named relative to
    it.  A live proposal keeps the configuration's file when no curve changed,
    else the corrected curves go to a file named by their content in the
    temporary folder (the nodes of a node set share the host).  The DV
    elements (their curves are pairs of the same file) are written beside the
    MVs' as the configuration gives them.
    """
    whole = augmented_model(update.model, config.disturbance_model)
    if not np.any(whole.element_type == "step_response"):
        return ""
    original = str(config.parameters.get("system", {}).get("model_file", ""))
    if model_path is not None:
        path = curve_file_path(model_path, original)
        write_curve_file(whole, path, original=original)
        return path.name
    if not any(c.element is not None and c.element.kind == "step_response" for c in update.changes):
        return original
    digest = hashlib.sha1(repr([c.element for c in update.changes]).encode()).hexdigest()[:16]
    path = curve_file_path(Path(tempfile.gettempdir()) / "pmr_ros_models" / f"proposed-{digest}.yaml", original)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_curve_file(whole, path, original=original)
    return str(path)


def model_file_text(
    config: PmrConfig,
    update: ModelUpdate,
    diagnosis: Diagnosis,
    *,
    window: Mapping[str, Any] | None = None,
    model_file: str = "",
) -> str:
    """The corrected model's params file: the configuration's other blocks kept, simulation truth left out.

    Parameters
    ----------
    config : PmrConfig
        The configuration the diagnosis ran with (its model is the one corrected).
    update : ModelUpdate
    diagnosis : Diagnosis
        The verdicts the update rests on: one comment line per element.
    window : mapping, optional
        ``first_sample``, ``last_sample`` of the diagnosed window (named in the header).
    model_file : str
        ``system.model_file`` of a model with step_response elements (:func:`curve_file`).

    Returns
    -------
    str
    """
    span = ""
    if window and "first_sample" in window:
        span = f" (samples {window['first_sample']}..{window['last_sample']})"
    header = [
        f"Corrected model of {config.model.name or 'the system'} written by pmr-ros from a {diagnosis.method} "
        f"diagnosis of {diagnosis.samples} samples{span} (configuration {config.source}).",
        "Elements with a mismatch verdict take their estimates; ok and inconclusive elements are the model's own.",
        *(f"changed {change.comment()}" for change in update.changes),
        *(
            ("the D elements' corrections above are not written below: change system.disturbance_* by hand",)
            if update.disturbance_changes
            else ()
        ),
        *(() if update.changes else ("no element has a mismatch verdict: the model is unchanged",)),
        *_verdict_lines(diagnosis),
    ]
    notes = {change.name: change.note() for change in update.changes}
    return model_params_text(
        update.model, settings=config.parameters, header=header, notes=notes, model_file=model_file
    )


@dataclass(frozen=True)
class ClosedWindow:
    """A verdict window closed: its outcome with the control impact, and the model it proposes.

    Attributes
    ----------
    outcome : WindowOutcome
        The window's outcome; a verdict's diagnosis carries its impact.
    proposal : str or None
        The corrected model's params file (:func:`model_file_text`, naming the
        window) when a mismatch verdict stands, else None.
    impact_note : str
        Why the control impact was not computed (:attr:`Closed.impact_note`), "" otherwise.
    """

    outcome: WindowOutcome
    proposal: str | None = None
    impact_note: str = ""


def close_window(outcome: WindowOutcome, config: PmrConfig) -> ClosedWindow:
    """:func:`close_diagnosis` of a window's verdict and its proposal; any other outcome as it is.

    The live diagnostician's worker runs this after the window's diagnosis: the
    impact's closed-loop simulations never run on the executor's thread.
    """
    if outcome.kind != VERDICT:
        return ClosedWindow(outcome)
    closed = close_diagnosis(outcome.diagnosis, config)
    proposal = None
    if closed.proposes and closed.update is not None:
        proposal = model_file_text(
            config,
            closed.update,
            closed.diagnosis,
            window=outcome.window,
            model_file=curve_file(config, closed.update),
        )
    return ClosedWindow(replace(outcome, diagnosis=closed.diagnosis), proposal, closed.impact_note)


def close_and_write(
    config: PmrConfig,
    diagnosis: Diagnosis,
    *,
    model_path: str | None = None,
    notes: list[str] | None = None,
    jobs: int = 1,
) -> Diagnosis:
    """The diagnosis with its control impact; the corrected model written to ``model_path`` if given.

    Parameters
    ----------
    config : PmrConfig
        The configuration the diagnosis ran with.
    diagnosis : Diagnosis
    model_path : str, optional
        Where to write the corrected model's params file (``--write-model``).
    notes : list of str, optional
        Receives why the control impact was not computed, when it was skipped
        (:attr:`Closed.impact_note`), for the command to print.
    jobs : int
        Worker processes for the impact's simulations (:func:`close_diagnosis`).

    Raises
    ------
    ServiceError
        ``model_path`` with a diagnosis that cannot give a corrected model (exit code 3).
    """
    closed = close_diagnosis(diagnosis, config, jobs=jobs)
    if closed.impact_note and notes is not None:
        notes.append(closed.impact_note)
    if closed.update is None:
        if model_path is not None:
            raise ServiceError(f"--write-model {model_path}: {closed.why_not}", code=EXIT_INSUFFICIENT)
        return diagnosis
    if model_path is not None:
        curves = curve_file(config, closed.update, model_path)
        write_params_file(model_path, model_file_text(config, closed.update, closed.diagnosis, model_file=curves))
    return closed.diagnosis
