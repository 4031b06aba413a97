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

__all__ = ["FORCE", "JSON", "QUIET", "SYSTEM_FILE", "WIDE", "Option", "add_options", "config_option", "option"]


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

WIDE = option(
    "--wide",
    action="store_true",
    help="also print each element's model and estimated plant side by side: K, tau, D with intervals, in the "
    "system's units (system.output_units, input_units, time_unit)",
)
"""``--wide``, of the commands that print the verdict table."""

FORCE = option("--force", action="store_true", help="overwrite what is at the output")
"""``--force``; each command says in its help what it overwrites (:meth:`Option.but`)."""

QUIET = option("--quiet", action="store_true", help="no progress bar")
"""``--quiet``."""
