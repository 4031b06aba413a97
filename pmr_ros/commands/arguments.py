"""Command-line options as data: one table per sub-command, the options several commands share written once.

An option is the flags and the keyword arguments of
:meth:`argparse.ArgumentParser.add_argument`; a command's ``register`` lists
its options (its own and the shared ones below) and :func:`add_options` adds
them in that order, so ``--help`` lists them as the table does.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from . import positive_float, positive_int

__all__ = [
    "FORCE",
    "JSON",
    "MONITOR",
    "MONITOR_OPTIONS",
    "QUIET",
    "SYSTEM_FILE",
    "Option",
    "add_options",
    "config_option",
    "option",
]


@dataclass(frozen=True)
class Option:
    """One command-line option: its flags and the keyword arguments of ``add_argument``.

    Attributes
    ----------
    flags : tuple of str
        ``("--config",)``, or a positional's name.
    settings : dict
        ``metavar``, ``type``, ``default``, ``help`` ...
    group : str
        The argument group it is listed under in ``--help`` ("": the command's own options).
    """

    flags: tuple[str, ...]
    settings: dict[str, Any] = field(default_factory=dict)
    group: str = ""

    def but(self, **settings: Any) -> Option:
        """A copy with some settings replaced (another help text, another default)."""
        return Option(self.flags, {**self.settings, **settings}, self.group)


def option(*flags: str, group: str = "", **settings: Any) -> Option:
    """An :class:`Option` of ``flags`` with the keyword arguments of ``add_argument``."""
    return Option(tuple(flags), settings, group)


def add_options(parser: argparse.ArgumentParser, options: Iterable[Option]) -> None:
    """Add ``options`` to ``parser`` in order, each group's under its heading."""
    groups: dict[str, Any] = {}
    for opt in options:
        target: Any = parser
        if opt.group:
            target = groups.setdefault(opt.group, parser.add_argument_group(opt.group))
        target.add_argument(*opt.flags, **opt.settings)


SYSTEM_FILE = "ROS 2 params file of the system (default: the shipped Wood-Berry column)"
"""The help of ``--config`` where the default is the shipped system."""


def config_option(help_text: str = SYSTEM_FILE) -> Option:
    """``--config FILE``: the params file (its help says where the default comes from for this command)."""
    return option("--config", metavar="FILE", help=help_text)


JSON = option("--json", metavar="FILE", help="also write the report as JSON")
"""``--json FILE``, of the commands that diagnose."""

FORCE = option("--force", action="store_true", help="overwrite what is at the output")
"""``--force``; each command says in its help what it overwrites (:meth:`Option.but`)."""

QUIET = option("--quiet", action="store_true", help="no progress bar")
"""``--quiet``."""


MONITOR = "rolling windows (a monitor over a long record)"
"""The heading of ``pmr-ros diagnose``'s rolling-window options."""

MONITOR_OPTIONS = (
    option(
        "--window",
        metavar="W",
        help="diagnose every window of W samples, or of clock time with a unit (14d, 6h, 30min, 90s) when the data "
        "have time stamps; the JSON gains 'windows' and each element its 'onset' (when it began to move, step or "
        "drift); the table shows the last window",
        group=MONITOR,
    ),
    option(
        "--step",
        metavar="S",
        help="--window: the step between window ends, in the window's unit (default: a quarter of the window)",
        group=MONITOR,
    ),
    option(
        "--trend",
        metavar="FILE",
        help="--window: also write one row per window and element (estimates, 95 %% intervals, verdicts, data "
        "quality) to FILE.csv or FILE.parquet",
        group=MONITOR,
    ),
    option(
        "--jobs",
        type=positive_int,
        metavar="N",
        help="--window, --fleet: worker processes (default: the number of cores; 1: in this process)",
        group=MONITOR,
    ),
    option(
        "--scheduler",
        metavar="ADDRESS",
        help="--window, --fleet: run on the Dask distributed cluster of this scheduler (e.g. tcp://10.0.0.5:8786) "
        "instead of local processes; the results are the same",
        group=MONITOR,
    ),
    option(
        "--connect-timeout",
        type=positive_float,
        metavar="S",
        help="--scheduler: give up when the scheduler has not answered in S seconds (default: 5)",
        group=MONITOR,
    ),
    option(
        "--fleet",
        metavar="FLEET.yaml",
        help="diagnose a fleet of controllers (a list of entries: name, params, data; optional window, step): "
        "one summary ranked by control impact (else by decided mismatch over its tolerance), and with --report "
        "an index page linking every controller's report; a failing entry is listed as failed, the others run",
        group=MONITOR,
    ),
    Option(QUIET.flags, {**QUIET.settings, "help": "--window, --fleet: say nothing while the windows run"}, MONITOR),
)
"""The options of ``pmr-ros diagnose --window`` and ``--fleet``."""
