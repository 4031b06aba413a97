"""Where the package's data folders (``config/``, ``msg_defs/``) are, however it was installed.

One lookup, in this order:

1. the source tree, when the package is imported from a checkout (editable
   install, ``colcon build --symlink-install``, or ``PYTHONPATH``);
2. the ament index (``AMENT_PREFIX_PATH``), when a ROS 2 workspace built by
   colcon is sourced: ``<prefix>/share/pmr_ros/<folder>``;
3. the installed ``share/pmr_ros/<folder>`` under the interpreter's prefixes
   (a plain ``pip install .``, where ``setup.py``'s ``data_files`` land).

No ROS import is needed: ``ament_index_python`` is used when it is there, and
``AMENT_PREFIX_PATH`` is read directly otherwise.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

__all__ = ["PACKAGE", "SOURCE_ROOT", "ResourceError", "ament_prefixes", "share_dir", "source_root"]

PACKAGE = "pmr_ros"
"""The ROS 2 package name (also the ament index resource)."""

SOURCE_ROOT = Path(__file__).resolve().parents[1]
"""The folder holding the ``pmr_ros`` package: the checkout's root when imported from one
(for an installed copy, ``site-packages``, where no data folder is)."""


def source_root() -> Path:
    """:data:`SOURCE_ROOT`, read when called (so tests can point it at a fake checkout).

    Returns
    -------
    Path
    """
    return SOURCE_ROOT


class ResourceError(FileNotFoundError):
    """A data folder of the package cannot be found; the message lists where it looked."""


def ament_prefixes() -> list[Path]:
    """The install prefix of the ament index that registers ``pmr_ros``, as a list.

    Returns
    -------
    list of Path
        The first prefix of ``AMENT_PREFIX_PATH`` whose index lists ``pmr_ros``
        (the one ``ros2 run`` uses: an overlay shadows its underlays), or an
        empty list when no sourced workspace has it.
    """
    try:
        from ament_index_python.packages import PackageNotFoundError, get_package_prefix
    except ImportError:
        prefixes = [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
        marker = Path("share") / "ament_index" / "resource_index" / "packages" / PACKAGE
        return [p for p in prefixes if (p / marker).is_file()][:1]
    try:
        return [Path(get_package_prefix(PACKAGE))]
    except (PackageNotFoundError, ValueError, OSError):  # OSError: AMENT_PREFIX_PATH unset
        return []


def _candidates(folder: str) -> list[Path]:
    source = source_root() / folder
    prefixes = [*ament_prefixes(), Path(sys.prefix), Path(sys.base_prefix)]
    installed = [p / "share" / PACKAGE / folder for p in prefixes]
    return [source, *dict.fromkeys(installed)]


def share_dir(folder: str, marker: str) -> Path:
    """The package data folder ``folder`` that holds the file ``marker``.

    Parameters
    ----------
    folder : str
        ``config`` or ``msg_defs``.
    marker : str
        A file the folder must hold (guards against a stale or unrelated folder).

    Returns
    -------
    Path

    Raises
    ------
    ResourceError
        When no candidate holds ``marker``; the message lists the places tried.

    Examples
    --------
    >>> (share_dir("msg_defs", "topics.yaml") / "topics.yaml").is_file()
    True
    """
    tried = _candidates(folder)
    for candidate in tried:
        if (candidate / marker).is_file():
            return candidate
    places = ", ".join(str(p) for p in tried)
    raise ResourceError(f"cannot find pmr_ros's {folder}/{marker} (looked in {places}); is pmr_ros installed?")
