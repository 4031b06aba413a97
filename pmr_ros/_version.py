"""pmr_ros's version, written in one place: ``package.xml`` (the ROS convention).

``setup.py`` reads it from there into the distribution's metadata; this module
gives it back at run time, in this order:

1. the ``package.xml`` beside the package, when it is imported from a checkout
   (``./test.sh``, ``colcon test``, ``PYTHONPATH=src``): that file is the truth,
   and the installed metadata may be older (an editable install keeps the
   version it was installed with until it is reinstalled);
2. ``importlib.metadata.version("pmr_ros")``, for an installed copy (``pip
   install .``, ``colcon build``);
3. ``share/pmr_ros/package.xml`` found like the data folders
   (:func:`pmr_ros.resources.share_dir`), for an install without metadata.
"""

from __future__ import annotations

import xml.etree.ElementTree as ElementTree
from pathlib import Path

from .resources import PACKAGE, ResourceError, share_dir, source_root

__all__ = ["UNKNOWN_VERSION", "package_version", "read_package_xml"]

UNKNOWN_VERSION = "0+unknown"
"""What :func:`package_version` gives when no source of the version can be read."""


def read_package_xml(path: Path) -> str:
    """The version of pmr_ros in the ROS package manifest ``path``.

    Parameters
    ----------
    path : Path
        A ``package.xml`` (format 2 or 3).

    Returns
    -------
    str
        The text of ``<version>``, stripped.

    Raises
    ------
    ValueError
        When ``path`` cannot be parsed, is the manifest of another package, or
        has no version.
    """
    try:
        root = ElementTree.parse(path).getroot()
    except (OSError, ElementTree.ParseError) as exc:
        raise ValueError(f"{path}: cannot read the package manifest ({exc})") from exc
    name = (root.findtext("name") or "").strip()
    if name != PACKAGE:
        # A package.xml of some other package next to site-packages must not lend its version.
        raise ValueError(f"{path}: the manifest of {name or 'no package'!r}, not {PACKAGE}")
    version = (root.findtext("version") or "").strip()
    if not version:
        raise ValueError(f"{path}: no <version>")
    return version


def package_version() -> str:
    """The version of this pmr_ros.

    Returns
    -------
    str
        The version, or :data:`UNKNOWN_VERSION` when none of the three sources
        in the module docstring can be read (never raises: importing pmr_ros
        must not fail over its version).
    """
    checkout = source_root() / "package.xml"
    if checkout.is_file():
        try:
            return read_package_xml(checkout)
        except ValueError:
            pass  # not ours (e.g. a stray package.xml in site-packages): ask the metadata
    from importlib import metadata  # here: about 20 ms to import, and a checkout does not need it

    try:
        return metadata.version(PACKAGE)
    except metadata.PackageNotFoundError:
        pass
    try:
        return read_package_xml(share_dir("", "package.xml") / "package.xml")
    except (ResourceError, ValueError):
        return UNKNOWN_VERSION
