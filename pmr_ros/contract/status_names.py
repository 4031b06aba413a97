"""The names of the diagnostician's /diagnostics statuses: path-like, for a diagnostic aggregator.

A status is named ``pmr/<namespace>/<system>/<element>`` (``pmr/wood_berry/G21``;
a node set started in namespace ``/column_a``: ``pmr/column_a/wood_berry/G21``)
and the verdict counts of the whole matrix ``pmr/<namespace>/<system>/summary``,
so a ``diagnostic_aggregator`` GenericAnalyzer groups one controller's
statuses by ``startswith: [pmr/wood_berry/]`` (``config/diagnostic_analyzers.yaml``).
The part before the element is the status *prefix*.  Statuses written before
these names (older bags, bags/wood_berry_full among them) were named ``<node name>: <element>``
(``pmr_diagnostician: G21``); :func:`split_status_name` reads both.  No ROS imports.
"""

from __future__ import annotations

import re

__all__ = ["ROOT", "SUMMARY", "split_status_name", "status_name", "status_prefix"]

ROOT = "pmr"
"""First segment of every status name of pmr_ros."""

SUMMARY = "summary"
"""Last segment of the status that counts the verdicts of the whole matrix (no element is named so)."""

_NOT_IN_SEGMENT = re.compile(r"[/\s]+")


def status_prefix(system_name: str, namespace: str = "/") -> str:
    """``pmr/<namespace segments>/<system>``: what every status of one diagnostician starts with.

    Parameters
    ----------
    system_name : str
        ``system.name``; empty: ``system``.  Slashes and blanks in it become ``_``
        (one path segment per system).
    namespace : str
        The diagnostician's ROS namespace (``/`` or ``/plant/column_a``).

    Examples
    --------
    >>> status_prefix("wood_berry"), status_prefix("wood_berry", "/column_a"), status_prefix("")
    ('pmr/wood_berry', 'pmr/column_a/wood_berry', 'pmr/system')
    """
    system = _NOT_IN_SEGMENT.sub("_", system_name.strip()) or "system"
    return "/".join([ROOT, *(part for part in namespace.split("/") if part), system])


def status_name(prefix: str, element: str) -> str:
    """The status name of ``element`` (or of :data:`SUMMARY`) under ``prefix``."""
    return f"{prefix}/{element}"


def split_status_name(name: str) -> tuple[str, str] | None:
    """``(owner, last part)`` of a status name in either spelling; None if it is no pmr_ros status.

    The owner is the prefix (``pmr/wood_berry``) of a path-like name, the node
    name of the older ``<node name>: <element>`` spelling.

    Examples
    --------
    >>> split_status_name("pmr/column_a/wood_berry/G21"), split_status_name("pmr_diagnostician: G21")
    (('pmr/column_a/wood_berry', 'G21'), ('pmr_diagnostician', 'G21'))
    >>> split_status_name("camera_driver/fps") is None
    True
    """
    owner, sep, last = name.partition(": ")
    if sep and last:
        return owner, last
    owner, sep, last = name.rpartition("/")
    if sep and last and owner.startswith(f"{ROOT}/"):
        return owner, last
    return None
