"""The ``--write-model FILE`` option of ``pmr-ros run`` and ``diagnose``: its argument and its check before any work.

``--write-model FILE`` writes a params file whose ``system`` block is the
controller's model with every ``mismatch`` element replaced by its estimate
(:mod:`pmr_ros.core.loop.update`), each change noted beside the element; the
control impact of the mismatches (:mod:`pmr_ros.core.loop.impact`) is computed
whenever a parametric diagnosis has a ``mismatch`` verdict and ``impact.samples``
is not 0 (both by :func:`pmr_ros.service.closing.close_and_write`, as the live diagnostician does).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from ..outputs import add_output_arguments
from . import CommandError

__all__ = ["add_model_arguments", "check_model_output"]


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
