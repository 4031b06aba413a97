"""Work done once per test session and shared by pytest-xdist's worker processes (for read-only results).

A module-scoped fixture runs once in every worker process that runs one of the module's tests, and
``pytest -n auto`` deals a module's tests to several workers: an expensive fixture then runs on each.
Here the first worker to ask makes the result under the session's temporary root (the parent of the
workers' own roots, new for each session, so nothing is ever reused from an earlier run); the others
wait for it and read it.
"""

from __future__ import annotations

import fcntl
import os
import pickle
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import pytest

T = TypeVar("T")


def session_root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The session's temporary root: shared by the xdist workers, the plain run's own otherwise."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


def shared_folder(tmp_path_factory: pytest.TempPathFactory, name: str, make: Callable[[Path], None]) -> Path:
    """The folder ``name`` that ``make(folder)`` fills, made once per session; the other workers wait for it.

    A ``make`` that raises leaves no mark: the next worker to ask tries again (and fails alike).
    """
    root = session_root(tmp_path_factory)
    folder, done = root / name, root / f"{name}.done"
    with (root / f"{name}.lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.exists():
            make(folder)
            done.touch()
    return folder


def shared_value(tmp_path_factory: pytest.TempPathFactory, name: str, compute: Callable[[], T]) -> T:
    """``compute()``, once per session (pickled under the session root); ``name`` must say every input."""

    def make(folder: Path) -> None:
        folder.mkdir(exist_ok=True)
        (folder / "value.pickle").write_bytes(pickle.dumps(compute()))

    folder = shared_folder(tmp_path_factory, name, make)
    return pickle.loads((folder / "value.pickle").read_bytes())  # noqa: S301 - written by this session


class SharedValues:
    """``shared(name, compute)``: :func:`shared_value`, kept in this process too (the ``shared`` fixture)."""

    def __init__(self, tmp_path_factory: pytest.TempPathFactory) -> None:
        self.tmp_path_factory, self.values = tmp_path_factory, {}

    def __call__(self, name: str, compute: Callable[[], T]) -> T:
        if name not in self.values:
            self.values[name] = shared_value(self.tmp_path_factory, name, compute)
        return self.values[name]
