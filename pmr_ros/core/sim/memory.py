"""How much memory a run needs, estimated before anything is allocated, and how much the machine has.

The figures per sample are upper bounds of what is measured
(``benchmarks/bench_memory.py`` prints both; ``test/test_memory.py`` checks
the bounds): a batch simulation keeps r, u, y and the MV dither of every
sample, the diagnosis transforms Welch frames of the instruments once and of
one output row (the output and its regressors) at a time (both measured with ``tracemalloc``),
and a live window holds each complete sample as three small arrays
(measured as resident memory, the allocator's overhead included).
"""

from __future__ import annotations

import os
from pathlib import Path

from .model import TransferMatrix

__all__ = [
    "DIAGNOSIS_BYTES_PER_CHANNEL",
    "SIMULATION_BYTES_PER_VALUE",
    "WINDOW_BYTES_PER_SAMPLE",
    "WINDOW_BYTES_PER_VALUE",
    "available_bytes",
    "diagnosis_bytes",
    "format_bytes",
    "memory_shortfall",
    "simulation_bytes",
    "window_bytes",
]

SIMULATION_BYTES_PER_VALUE = 16
"""Simulation: bytes per sample per recorded value (r, y, u, dither and the generators' temporaries); 10 measured."""

DIAGNOSIS_BYTES_PER_CHANNEL = 56
"""Diagnosis: bytes per sample per spectral channel (the instruments, then one output row at a time: the
output and its regressors); 41-49 measured on Wood-Berry and the 3x3 at 8,192 samples (the parametric fit
keeps a row's whitened regressors for its weightings: 49 on Wood-Berry, 42 for the classic PMR)."""

WINDOW_BYTES_PER_SAMPLE = 700
"""A live window: bytes per complete sample held (three small arrays and their bookkeeping); about 500 measured."""

WINDOW_BYTES_PER_VALUE = 8
"""A live window: bytes per value of a complete sample held (float64)."""


def simulation_bytes(model: TransferMatrix, samples: int, *, runs: int = 1) -> int:
    """Memory a batch simulation of ``runs`` runs of ``samples`` samples needs [bytes]."""
    values = 2 * model.n_outputs + 2 * model.n_inputs
    return SIMULATION_BYTES_PER_VALUE * values * int(samples) * int(runs)


def diagnosis_bytes(model: TransferMatrix, samples: int, *, dither: bool = False) -> int:
    """Memory the diagnosis of ``samples`` samples needs at its peak [bytes].

    Parameters
    ----------
    model : TransferMatrix
        The controller's model (its outputs, inputs and elements are the channels).
    samples : int
        Samples diagnosed.
    dither : bool
        Whether the MV dither joins the setpoints as instruments.
    """
    instruments = model.n_outputs + (model.n_inputs if dither else 0)
    # the instruments' transforms are kept; the rows' are made one at a time (core.spectra.RecordSpectra)
    channels = instruments + 1 + model.n_inputs
    return DIAGNOSIS_BYTES_PER_CHANNEL * channels * int(samples)


def window_bytes(model: TransferMatrix, samples: int) -> int:
    """Memory a live window of ``samples`` complete samples of r, u and y holds [bytes]."""
    values = 2 * model.n_outputs + model.n_inputs
    return (WINDOW_BYTES_PER_SAMPLE + WINDOW_BYTES_PER_VALUE * values) * int(samples)


def available_bytes() -> int | None:
    """Memory the machine can give now without swapping [bytes]: ``MemAvailable``, else free pages; None if unknown."""
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def format_bytes(value: float) -> str:
    """``2.4 GB``, ``310 MB``: a size for people (powers of 1000)."""
    for unit, size in (("EB", 1e18), ("PB", 1e15), ("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if value >= size:
            return f"{value / size:.3g} {unit}"
    return f"{value:.0f} B"


def memory_shortfall(parts: dict[str, int]) -> str | None:
    """Why work needing ``parts`` [bytes] cannot fit in the memory available now, in words; None when it fits.

    Unknown available memory (no ``/proc/meminfo``) is taken to fit.

    Parameters
    ----------
    parts : dict
        What needs memory -> bytes (``{"plant realization": 3 * 10**12}``).

    Examples
    --------
    >>> memory_shortfall({"a": 1}) is None
    True
    """
    needed, have = sum(parts.values()), available_bytes()
    if have is None or needed <= have:
        return None
    detail = ", ".join(f"{name} {format_bytes(n)}" for name, n in parts.items())
    return f"needs about {format_bytes(needed)} of memory ({detail}); {format_bytes(have)} available"
