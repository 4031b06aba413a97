"""Large arrays to pool workers through memory-mapped files instead of the pool's pipe.

A pool from the ``forkserver`` context (:func:`pmr_ros.core.sim.workers.worker_context`) sends each worker
its initializer's arguments through a socket, pickled whole: a year of 1-minute data of a 4x8 controller
(101 MB) took 2.3 s of the monitor's start on this 2-core machine, with the parent blocked.  :func:`ship`
pickles an object with every large array written to a ``.npy`` file of a folder instead, and
:func:`unship` gives it back with those arrays memory-mapped read-only: the workers share the pages the
operating system already caches, and the pickle that travels is a few kilobytes.
"""

from __future__ import annotations

import io
import pickle
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["SHIPPED_MIN_BYTES", "ship", "unship"]

SHIPPED_MIN_BYTES = 1 << 20
"""Arrays of at least this many bytes go to a file; smaller ones travel in the pickle [bytes]."""


def _mapped(path: str) -> np.ndarray:
    """The array of ``path``, memory-mapped read-only (its users make new arrays from it, never write it).

    A plain ndarray over the map (which it keeps open): every slice of a :class:`numpy.memmap` would be one
    too, and its operations pay the subclass's wrapping.
    """
    return np.load(path, mmap_mode="r").view(np.ndarray)


class _Shipper(pickle.Pickler):
    """A pickler that writes each large numeric array to its own file and pickles a reference to it."""

    def __init__(self, file: io.BytesIO, folder: Path, min_bytes: int) -> None:
        super().__init__(file, protocol=pickle.HIGHEST_PROTOCOL)
        self.folder, self.min_bytes, self.files = folder, min_bytes, 0

    def reducer_override(self, obj: Any) -> Any:
        if type(obj) is not np.ndarray or obj.nbytes < self.min_bytes or obj.dtype.hasobject:
            return NotImplemented
        path = self.folder / f"array_{self.files:04d}.npy"
        self.files += 1
        np.save(path, obj, allow_pickle=False)
        return _mapped, (str(path),)


def ship(obj: Any, folder: Path, *, min_bytes: int = SHIPPED_MIN_BYTES) -> bytes:
    """``obj`` pickled, its arrays of ``min_bytes`` or more written to ``folder`` (which must outlive its users).

    Parameters
    ----------
    obj : object
        Anything picklable.
    folder : Path
        An existing folder, e.g. a temporary one kept until the pool is joined.
    min_bytes : int
        The smallest array written to a file [bytes].

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     back = unship(ship({"y": np.arange(300_000.0)}, Path(folder)))
    ...     (back["y"][-1], isinstance(back["y"].base, np.memmap), back["y"].flags.writeable)
    (np.float64(299999.0), True, False)
    """
    buffer = io.BytesIO()
    _Shipper(buffer, Path(folder), min_bytes).dump(obj)
    return buffer.getvalue()


def unship(blob: bytes) -> Any:
    """The object :func:`ship` pickled, its large arrays memory-mapped read-only from their files."""
    return pickle.loads(blob)
