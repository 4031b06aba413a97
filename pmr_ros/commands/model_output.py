"""What ``pmr-ros run`` and ``diagnose`` do after a diagnosis: the control impact and the corrected model.

``--write-model FILE`` writes a params file whose ``system`` block is the
controller's model with every ``mismatch`` element replaced by its estimate
(:mod:`pmr_ros.core.update`), each change noted beside the element; the
control impact of the mismatches (:mod:`pmr_ros.core.impact`) is computed
whenever a parametric diagnosis has a ``mismatch`` verdict and ``impact.samples``
is not 0 (both by :mod:`pmr_ros.contract.proposal`, as the live diagnostician does).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from ..config import PmrConfig
from ..config.write import write_params_file
from ..contract.proposal import close_diagnosis, model_file_text
from ..core.results import Diagnosis
from ..outputs import add_output_arguments
from . import CommandError

__all__ = ["add_model_arguments", "check_model_output", "close_the_loop"]


def add_model_arguments(parser: argparse.ArgumentParser) -> None:
    """``--write-model FILE``, shared by the commands that diagnose."""
    parser.add_argument(
        "--write-model",
        metavar="FILE",
        help="write the corrected model: the controller's model with every mismatched element replaced by its "
        "estimate, as a params file every pmr_ros command and node reads (parametric method)",
    )
    add_output_arguments(parser)


def check_model_output(args: argparse.Namespace) -> None:
    """Refuse before any work an unwritable ``--write-model`` path (one line)."""
    path = getattr(args, "write_model", None)
    if path is None:
        return
    folder = Path(path).resolve().parent
    exists_readonly = Path(path).exists() and not os.access(path, os.W_OK)
    if not folder.is_dir() or not os.access(folder, os.W_OK) or exists_readonly:
        raise CommandError(f"--write-model {path}: cannot write there (no such folder or no permission)")


def close_the_loop(args: argparse.Namespace, config: PmrConfig, diagnosis: Diagnosis) -> Diagnosis:
    """The diagnosis with its control impact; writes ``--write-model`` if asked.

    Raises
    ------
    CommandError
        ``--write-model`` with a diagnosis that cannot give a corrected model.
    """
    path = getattr(args, "write_model", None)
    closed = close_diagnosis(diagnosis, config)
    if closed.update is None:
        if path is not None:
            raise CommandError(f"--write-model {path}: {closed.why_not}", code=3) from None
        return diagnosis
    if path is not None:
        write_params_file(path, model_file_text(config, closed.update, closed.diagnosis))
    return closed.diagnosis
