"""Where :func:`~pmr_ros.core.pmr.spectra.record_spectra` may take a record's spectra already at hand.

A source is called with ``(stretches, model, welch, moving=...)`` (``moving``: the stretches'
instruments when the caller has them, else None) and returns spectra equal
to :class:`~pmr_ros.core.pmr.spectra.RecordSpectra`'s of those data, or None
for data it does not hold (they are then computed as usual).  The rolling
monitor (:mod:`pmr_ros.core.pmr.piecewise`) sets one around each window, so
that the stretches its overlapping windows share are filtered and transformed
once.  A context variable, so that a source set in one thread or task is seen
by no other.
"""

from __future__ import annotations

from collections.abc import Callable
from contextvars import ContextVar
from typing import Any

__all__ = ["SPECTRA_SOURCE"]

SPECTRA_SOURCE: ContextVar[Callable[..., Any] | None] = ContextVar("SPECTRA_SOURCE", default=None)
"""The source of spectra in this context (None: every record's spectra are computed)."""
