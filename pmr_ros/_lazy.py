"""Names of a package's front file that load on first use, from the module that defines them.

A front file (``pmr_ros/core/sim/__init__.py`` ...) names what its package
offers in ``__all__`` without importing every module: a node that needs one
module does not pay for the rest (the plant node never loads osqp).  Each
front file maps its names to their modules and takes its module-level
``__getattr__`` and ``__dir__`` (PEP 562) from :func:`lazy_exports`.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterable, Mapping
from typing import Any

__all__ = ["lazy_exports"]


def lazy_exports(
    package: str, where: Mapping[str, str], names: Iterable[str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """A front file's ``__getattr__`` and ``__dir__`` for names defined in its modules.

    Parameters
    ----------
    package : str
        The front file's ``__name__`` (e.g. ``"pmr_ros.core.sim"``).
    where : mapping of str to str
        Each exported name -> the module that defines it, relative to ``package``
        (``"model"``, ``"parametric.settings"``).
    names : iterable of str
        The front file's ``__all__`` (what ``dir()`` lists besides its globals).

    Returns
    -------
    (__getattr__, __dir__)

    Examples
    --------
    >>> getattr_, dir_ = lazy_exports("json", {"JSONDecoder": "decoder"}, ["JSONDecoder"])
    >>> getattr_("JSONDecoder").__name__
    'JSONDecoder'
    """
    listed = sorted(set(names))

    def __getattr__(name: str) -> Any:
        if name not in where:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        return getattr(importlib.import_module(f".{where[name]}", package), name)

    def __dir__() -> list[str]:
        return sorted({*vars(importlib.import_module(package)), *listed})

    return __getattr__, __dir__
