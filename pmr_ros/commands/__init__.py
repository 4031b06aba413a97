"""Sub-commands of ``pmr-ros``: each module has ``register(subparsers)``; here the checks they share.

One module per sub-command (``run``, ``sweep``, ``record``, ``replay``,
``diagnose``, ``reindex``, ``model_files`` for ``pmr-ros model``), the option
tables in ``arguments`` and ``sweep_options``; this file holds the argument
types and checks every command uses.  Commands parse and print; the work is
done by :mod:`pmr_ros.service` and the core.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = [
    "CommandError",
    "EXIT_INSUFFICIENT",
    "EXIT_INTERRUPTED",
    "EXIT_USAGE",
    "add_method_argument",
    "add_namespace_argument",
    "add_system_arguments",
    "check_memory",
    "declared_int",
    "grammar_number",
    "load_checked_config",
    "namespace",
    "nonnegative_float",
    "nonnegative_int",
    "number",
    "positive_float",
    "positive_int",
    "run_overrides",
    "whole_number",
    "writable_file",
]


class CommandError(Exception):
    """A user-facing failure: printed as ``pmr-ros: error: ...``, exit code attached."""

    def __init__(self, message: str, code: int = 2) -> None:
        super().__init__(message)
        self.code = code


EXIT_USAGE = 2
EXIT_INSUFFICIENT = 3
EXIT_INTERRUPTED = 130


def grammar_number(text: str) -> float:
    """``text`` as a float in pmr_ros's one number grammar (:mod:`pmr_ros.config.numbers`); ValueError if it is none."""
    from ..config.numbers import parse_number

    value = parse_number(text)
    if value is None:
        if text.strip().lstrip("+-.").lower() in ("nan", "inf", "infinity"):
            return float(text.replace(".", ""))  # a non-finite number: the range check names it
        raise ValueError(text)
    return float(value)


def whole_number(text: str) -> int:
    """``text`` as an int in the grammar (``1e9`` is whole, ``0x10`` and ``1_000`` are no numbers); else ValueError."""
    from ..config.numbers import parse_number

    value = parse_number(text)
    if isinstance(value, int):
        return value
    if value is None or not math.isfinite(value) or value != int(value):
        raise ValueError(text)
    return int(value)


def positive_int(text: str) -> int:
    """Argparse type: a whole number > 0."""
    try:
        value = whole_number(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"{value} must be > 0")
    return value


def number(text: str) -> float:
    """Argparse type: a number (its range is checked by the command, with a clearer message)."""
    try:
        return grammar_number(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None


def writable_file(path: str, option: str) -> None:
    """Check, before any work, that ``path`` (given with ``option``) can be written; else :class:`CommandError`.

    A file that does not exist yet is created and removed again; one that
    exists is opened for appending, not changed.
    """
    target = Path(path)
    if target.is_dir():
        raise CommandError(f"{option} {path}: is a folder, not a file")
    existed = target.exists()
    try:
        with target.open("a", encoding="utf-8"):
            pass
    except OSError as exc:
        raise CommandError(f"{option} {path}: cannot write: {exc.strerror or exc}") from None
    if not existed:
        target.unlink(missing_ok=True)


def check_memory(parts: dict[str, int], *, cause: str, advice: str = "use fewer samples") -> None:
    """Refuse, before allocating, work whose estimated memory exceeds what the machine has available now.

    Parameters
    ----------
    parts : dict
        What needs memory -> bytes (see :mod:`pmr_ros.core.sim.memory`).
    cause : str
        The setting that asks for it (``run.samples = 2000000000 (command line)``).
    advice : str
        What to do instead.

    Raises
    ------
    CommandError
        One line with the figures.
    """
    from ..core.sim.memory import memory_shortfall

    problem = memory_shortfall(parts)
    if problem is not None:
        raise CommandError(f"{cause}: {problem}: {advice}")


def declared_int(name: str) -> Callable[[str], int]:
    """Argparse type: a whole number in the declared range of parameter ``name`` (one source of truth).

    Examples
    --------
    >>> declared_int("simulation.max_samples_ahead")("256")
    256
    """
    from ..config import ConfigError
    from ..config.schema import parameter

    spec = parameter(name)

    def convert(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
        try:
            return int(spec.check(value, source="command line"))
        except ConfigError:
            raise argparse.ArgumentTypeError(f"{value} must be {spec.range_text()} (the range of {name})") from None

    return convert


def nonnegative_float(text: str) -> float:
    """Argparse type: a finite number >= 0."""
    try:
        value = grammar_number(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"{text} must be a finite number >= 0")
    return value


def positive_float(text: str) -> float:
    """Argparse type: a finite number > 0."""
    try:
        value = grammar_number(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"{text} must be a finite number > 0")
    return value


def nonnegative_int(text: str) -> int:
    """Argparse type: a whole number >= 0."""
    try:
        value = whole_number(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"{value} must be >= 0")
    return value


def namespace(text: str) -> str:
    """Argparse type: a ROS node namespace (``column_a`` or ``/plant/column_a``), made absolute."""
    from ..contract.topics import ContractError, check_namespace

    try:
        return check_namespace(text)
    except ContractError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_namespace_argument(parser: argparse.ArgumentParser, help_text: str) -> None:
    """--namespace NS, shared by run, record, replay and diagnose."""
    parser.add_argument("--namespace", type=namespace, default=None, metavar="NS", help=help_text)


def add_system_arguments(parser: argparse.ArgumentParser) -> None:
    """--config/--scenario/--samples/--seed, shared by commands that simulate."""
    from ..core.sim.model import SCENARIOS
    from .arguments import add_options, config_option, option

    add_options(
        parser,
        [
            config_option(),
            option(
                "--scenario",
                choices=SCENARIOS,
                help="which part of the configured mismatch the plant gets (default: run.scenario)",
            ),
            option("--samples", type=positive_int, metavar="N", help="closed-loop samples (default: run.samples)"),
            option(
                "--seed", type=nonnegative_int, metavar="S", help="seed of noise and PRBS phase (default: run.seed)"
            ),
        ],
    )


def add_method_argument(parser: argparse.ArgumentParser) -> None:
    """--method classic|parametric, shared by commands that diagnose."""
    from ..core.pmr.diagnosis import METHODS

    parser.add_argument(
        "--method",
        choices=METHODS,
        help="classic: the paper's Table 1 (gain ratio, tau index, delay); parametric: fitted dK %%, dtau %%, dD with "
        "confidence intervals and ok/mismatch/inconclusive verdicts (default: pmr.method of the config)",
    )


def run_overrides(args: argparse.Namespace) -> dict:
    """Config overrides from the options of :func:`add_system_arguments` and :func:`add_method_argument`."""
    overrides: dict = {}
    run = {}
    for name in ("samples", "seed", "scenario"):
        value = getattr(args, name, None)
        if value is not None:
            run[name] = value
    if run:
        overrides["run"] = run
    if getattr(args, "method", None) is not None:
        overrides["pmr"] = {"method": args.method}
    return overrides


def load_checked_config(path: str | None, overrides: dict | None = None) -> Any:
    """:func:`pmr_ros.config.load_config`, printing its warnings (``pmr-ros: warning: ...``) on stderr."""
    import sys

    from ..config import load_config

    config = load_config(path, overrides)
    for warning in config.warnings:
        print(f"pmr-ros: warning: {warning}", file=sys.stderr)
    return config
