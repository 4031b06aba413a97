"""What ``pmr-ros run`` and ``diagnose`` do after a diagnosis: the control impact and the corrected model.

``--write-model FILE`` writes a params file whose ``system`` block is the
controller's model with every ``mismatch`` element replaced by its estimate
(:mod:`pmr_ros.core.update`), each change noted beside the element; the
control impact of the mismatches (:mod:`pmr_ros.core.impact`) is computed
whenever a parametric diagnosis has a ``mismatch`` verdict and ``impact.samples``
is not 0.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from ..config import PmrConfig
from ..config.write import model_params_text, write_params_file
from ..core.impact import control_impact
from ..core.results import Diagnosis
from ..core.update import ModelUpdate, NotCorrectable, corrected_model
from . import CommandError

__all__ = ["add_model_arguments", "check_model_output", "close_the_loop", "model_file_text"]


def add_model_arguments(parser: argparse.ArgumentParser) -> None:
    """``--write-model FILE``, shared by the commands that diagnose."""
    parser.add_argument(
        "--write-model",
        metavar="FILE",
        help="write the corrected model: the controller's model with every mismatched element replaced by its "
        "estimate, as a params file every pmr_ros command and node reads (parametric method)",
    )


def check_model_output(args: argparse.Namespace) -> None:
    """Refuse before any work an unwritable ``--write-model`` path (one line)."""
    path = getattr(args, "write_model", None)
    if path is None:
        return
    folder = Path(path).resolve().parent
    exists_readonly = Path(path).exists() and not os.access(path, os.W_OK)
    if not folder.is_dir() or not os.access(folder, os.W_OK) or exists_readonly:
        raise CommandError(f"--write-model {path}: cannot write there (no such folder or no permission)")


def model_file_text(config: PmrConfig, update: ModelUpdate, diagnosis: Diagnosis) -> str:
    """The corrected model's params file (the configuration's other blocks kept, simulation truth left out)."""
    header = [
        f"Corrected model of {config.model.name or 'the system'} written by pmr-ros from a {diagnosis.method} "
        f"diagnosis of {diagnosis.samples} samples (configuration {config.source}).",
        "Elements with a mismatch verdict take their estimates; ok and inconclusive elements are the model's own.",
        *(f"changed {change.comment()}" for change in update.changes),
        *(() if update.changes else ("no element has a mismatch verdict: the model is unchanged",)),
    ]
    notes = {change.name: change.note() for change in update.changes}
    return model_params_text(update.model, settings=config.parameters, header=header, notes=notes)


def close_the_loop(args: argparse.Namespace, config: PmrConfig, diagnosis: Diagnosis) -> Diagnosis:
    """The diagnosis with its control impact; writes ``--write-model`` if asked.

    Raises
    ------
    CommandError
        ``--write-model`` with a diagnosis that cannot give a corrected model.
    """
    path = getattr(args, "write_model", None)
    try:
        update = corrected_model(config.model, diagnosis)
    except NotCorrectable as exc:
        if path is not None:
            raise CommandError(f"--write-model {path}: {exc}", code=3) from None
        return diagnosis
    if config.impact.active and update.changes:
        diagnosis = control_impact(diagnosis, loop=config, update=update, samples=config.impact.samples)
    if path is not None:
        write_params_file(path, model_file_text(config, update, diagnosis))
    return diagnosis
