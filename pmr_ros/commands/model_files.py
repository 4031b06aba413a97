"""``pmr-ros model import|export``: a DMCplus ``.mdl`` (or CSV) model to a params file and back.

``import FILE.mdl -o MODEL.yaml`` writes a params file whose ``system`` block
names the curve file and holds a ``step_response`` element per pair;
``export MODEL.yaml -o FILE.mdl`` samples every element of a params file
(any element type) into step-response curves and writes them as ``.mdl`` or
``.csv`` (by the suffix).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from . import CommandError, positive_int, writable_file


def register(sub) -> None:
    """Add ``pmr-ros model`` with its ``import`` and ``export`` actions."""
    p = sub.add_parser(
        "model",
        help="import a DMCplus .mdl (or CSV) step-response model as a params file, or export a params file as .mdl",
        description="Convert between model files: DMCplus .mdl or CSV step-response curves (docs/models.md) and the "
        "params file's system block.",
    )
    actions = p.add_subparsers(dest="action", metavar="ACTION", required=True)
    imp = actions.add_parser("import", help="a .mdl or .csv curve file -> a params file naming it")
    imp.add_argument("model_file", metavar="FILE", help="DMCplus .mdl or .csv step-response curves")
    imp.add_argument("-o", "--output", required=True, metavar="MODEL.yaml", help="the params file to write")
    imp.add_argument("--name", help="system.name (default: the file's name)")
    imp.add_argument(
        "--disturbances",
        metavar="TAG,...",
        default="",
        help="independents of the file that are measured disturbances (DMCplus feedforward variables): "
        "system.disturbance_names with their D elements; the other independents are the MVs",
    )
    imp.set_defaults(handler=handle_import)
    exp = actions.add_parser("export", help="a params file (any element types) -> a .mdl or .csv curve file")
    exp.add_argument("params", metavar="MODEL.yaml", help="params file with a system block")
    exp.add_argument("-o", "--output", required=True, metavar="FILE", help="the .mdl or .csv file to write")
    exp.add_argument(
        "--coefficients",
        type=positive_int,
        metavar="N",
        help="coefficients per curve (default: those of the model's curve file, else until every element settles)",
    )
    exp.set_defaults(handler=handle_export)


def _suffix(path: str) -> str:
    suffix = Path(path).suffix.lower()
    if suffix not in (".mdl", ".csv"):
        raise CommandError(f"{path}: unknown model file type {suffix or '(none)'!r}: use a DMCplus .mdl or a .csv")
    return suffix


def handle_import(args: argparse.Namespace) -> int:
    """Run ``pmr-ros model import``; the exit code."""
    from ..config.write import write_params_file
    from ..models.curve_set import ModelFileError
    from ..models.system_file import import_params_text, read_curves, relative_model_file

    _suffix(args.model_file)
    writable_file(args.output, "-o")
    try:
        curves = read_curves(args.model_file)
    except ModelFileError as exc:
        raise CommandError(str(exc)) from None
    disturbances = tuple(tag.strip() for tag in args.disturbances.split(",") if tag.strip())
    try:
        text = import_params_text(
            curves,
            model_file=relative_model_file(args.model_file, args.output),
            name=args.name or Path(args.model_file).stem,
            source=Path(args.model_file).name,
            disturbances=disturbances,
        )
    except ModelFileError as exc:
        raise CommandError(f"--disturbances {args.disturbances}: {exc}") from None
    write_params_file(args.output, text)
    n_out, n_in, n = curves.curves.shape
    dvs = f" and {len(disturbances)} measured disturbance(s)" if disturbances else ""
    print(
        f"pmr-ros model: {n_out}x{n_in - len(disturbances)} step-response model{dvs} of {n} coefficients "
        f"(Ts {curves.sample_time:g}) from {args.model_file} written to {args.output}",
        file=sys.stderr,
    )
    return 0


def handle_export(args: argparse.Namespace) -> int:
    """Run ``pmr-ros model export``; the exit code."""
    from ..core.sim.lti import ElementError
    from ..models.csv_curves import write_csv_curves
    from ..models.curve_set import ModelFileError
    from ..models.mdl import write_mdl
    from ..models.system_file import load_model, to_curve_set

    suffix = _suffix(args.output)
    writable_file(args.output, "-o")
    try:
        model = load_model(args.params)
        curves = to_curve_set(model, args.coefficients)
        (write_mdl if suffix == ".mdl" else write_csv_curves)(curves, args.output)
    except (ModelFileError, ElementError) as exc:
        raise CommandError(str(exc)) from None
    n_out, n_in, n = curves.curves.shape
    print(
        f"pmr-ros model: {n_out}x{n_in} model of {args.params} written to {args.output} as curves of {n} coefficients",
        file=sys.stderr,
    )
    return 0
