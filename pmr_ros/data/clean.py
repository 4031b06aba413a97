"""Cleaning plant data on the sample grid: frozen tags, controller modes, MVs at a limit, clean stretches.

Every step is counted (:class:`CleaningStep`), so the report says what was
removed and why.  A sample is usable when r, u, y (and a logged dither and
DVs) are all valid there, its mode is known and at least one MV's controller
was on; an MV whose controller was off is kept as manual (open loop for it,
:attr:`Record.manual`).  The usable samples form unbroken stretches, each
diagnosed as its own record and averaged into one estimate
(:func:`pmr_ros.core.pmr.diagnosis.diagnose_stretches`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..core.records import Record

__all__ = [
    "NOISY_REPEAT_SHARE",
    "CleaningStep",
    "PlantData",
    "at_limit",
    "frozen",
    "mode_known",
    "mode_on",
    "repeat_runs",
    "runs",
]

NOISY_REPEAT_SHARE = 0.2
"""A tag repeating its value between fewer than this share of consecutive samples is normally noisy.

Only such a tag can be frozen: a setpoint, a held MV or an analyzer that
updates every few samples repeats its value by nature."""


@dataclass(frozen=True)
class CleaningStep:
    """One step of the cleaning and what it did.

    Attributes
    ----------
    name : str
        What the step does (``bad values -> missing``).
    count : int
        Cells or samples affected.
    unit : str
        ``cells``, ``samples`` or ``rows``.
    detail : str
        Per column or per period, for people.
    """

    name: str
    count: int
    unit: str
    detail: str = ""


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """The ``[start, stop)`` bounds of every run of True in a boolean array."""
    padded = np.concatenate([[False], np.asarray(mask, dtype=bool), [False]])
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def repeat_runs(x: np.ndarray) -> list[tuple[int, int]]:
    """``[start, stop)`` of every run of two or more equal consecutive valid values."""
    x = np.asarray(x, dtype=float)
    same = np.isfinite(x[1:]) & (x[1:] == x[:-1])
    return [(a, b + 1) for a, b in runs(same)]


def _normally_noisy(x: np.ndarray) -> bool:
    x = np.asarray(x, dtype=float)
    both = np.isfinite(x[1:]) & np.isfinite(x[:-1])
    if both.sum() < 2:
        return False
    return float(np.mean(x[1:][both] == x[:-1][both])) < NOISY_REPEAT_SHARE


def frozen(x: np.ndarray, limit: int, *, keep: np.ndarray | None = None) -> np.ndarray:
    """Samples of a normally noisy tag inside a run of one value longer than ``limit`` samples.

    Parameters
    ----------
    x : ndarray, shape (N,)
        The tag (NaN missing).
    limit : int
        ``data.frozen_samples``; 0 turns the check off [samples].
    keep : ndarray of bool, optional
        Samples never counted frozen (an MV at its limit).
    """
    out = np.zeros(np.shape(x)[0], dtype=bool)
    if limit <= 0 or not _normally_noisy(x):
        return out
    for a, b in repeat_runs(x):
        if b - a > limit:
            out[a:b] = True
    if keep is not None:
        out &= ~keep
    return out


def at_limit(u: np.ndarray) -> np.ndarray:
    """Samples where an input sits at its lowest or highest value of the record for two samples or more.

    An MV held at a limit is still data (the controller saturates), so it is
    flagged, not removed; a run of one value elsewhere may be a frozen tag.
    """
    u = np.asarray(u, dtype=float)
    out = np.zeros(u.shape[0], dtype=bool)
    valid = u[np.isfinite(u)]
    if valid.size == 0:
        return out
    low, high = valid.min(), valid.max()
    tolerance = 1e-9 * (1.0 + high - low)
    extreme = (np.abs(u - low) <= tolerance) | (np.abs(u - high) <= tolerance)
    for a, b in repeat_runs(u):
        if extreme[a]:
            out[a:b] = True
    return out


def mode_on(mode: np.ndarray, on_values: Sequence[float | str]) -> np.ndarray:
    """Whether each mode cell is one of ``on_values``.

    Numbers compare as numbers, text stripped and regardless of case
    (``auto`` is ``AUTO``); a boolean cell (a boolean mode column) is on when
    True, and so is the text ``true`` (a boolean column exported as text).
    """
    numbers = {float(v) for v in on_values if not isinstance(v, str)}
    strings = {v.strip().casefold() for v in on_values if isinstance(v, str)} | {"true"}
    out = np.zeros(len(mode), dtype=bool)
    for j, cell in enumerate(mode):
        if isinstance(cell, bool | np.bool_):
            out[j] = bool(cell)
        elif isinstance(cell, str):
            text = cell.strip()
            out[j] = text.casefold() in strings or _as_number(text) in numbers
        elif cell is not None:
            try:
                out[j] = float(cell) in numbers
            except (TypeError, ValueError):
                out[j] = False
    return out


def mode_known(mode: np.ndarray, bad_values: Sequence[float | str]) -> np.ndarray:
    """Whether each mode cell holds a mode: not missing (None, NaN, empty) nor one of ``data.bad_values``.

    A cell that is not known is neither on nor off: its sample is excluded.

    Examples
    --------
    >>> cells = np.array(["AUTO", None, float("nan"), "Bad", -9999, 0, "nan", True], dtype=object)
    >>> mode_known(cells, (-9999, "Bad", "")).tolist()
    [True, False, False, False, False, True, False, True]
    """
    numbers = {float(v) for v in bad_values if not isinstance(v, str)}
    strings = {v.strip().casefold() for v in bad_values if isinstance(v, str)} | {""}
    out = np.ones(len(mode), dtype=bool)
    for j, cell in enumerate(mode):
        if isinstance(cell, bool | np.bool_):
            continue
        if isinstance(cell, str) and cell.strip().casefold() in strings:
            out[j] = False
            continue
        number = _as_number(cell) if isinstance(cell, str) else _as_float(cell)
        if isinstance(cell, str) and number is None:
            continue  # a text mode (AUTO, MAN)
        out[j] = number is not None and bool(np.isfinite(number)) and number not in numbers
    return out


def _as_float(cell: object) -> float | None:
    try:
        return float(cell)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None


def _as_number(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


@dataclass(frozen=True)
class PlantData:
    """Plant data on the sample grid, cleaned, with what was removed and why.

    Attributes
    ----------
    source : str
        The file (or bag) the data came from.
    start : str
        The time of sample 0 (ISO text, or seconds).
    sample_time_s : float
        Ts [s].
    signals : dict
        ``r``, ``u``, ``y`` (and ``dither``) to arrays of shape (samples, channels), NaN missing.
    columns : dict
        The same keys to the file's column of each channel.
    excluded : dict
        Why samples are not used (``missing``, ``frozen``, ``controller off``) to a bool array (samples,).
    limited : ndarray of bool, shape (samples, n_inputs)
        Inputs at a limit (flagged, kept).
    steps : tuple of CleaningStep
    manual : ndarray of bool, shape (samples, n_inputs), optional
        Where an MV's controller was off (kept: open loop for it); None when all were on.
    outliers : dict
        The keys of ``signals`` to bool arrays of their shape: the gross
        outliers dropped (now NaN; :mod:`pmr_ros.data.outliers`).  Empty: none looked for.
    """

    source: str
    start: str
    sample_time_s: float
    signals: dict[str, np.ndarray]
    columns: dict[str, tuple[str, ...]]
    excluded: dict[str, np.ndarray]
    limited: np.ndarray
    steps: tuple[CleaningStep, ...]
    manual: np.ndarray | None = None
    outliers: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def samples(self) -> int:
        """Grid points from the first row to the last."""
        return int(self.signals["r"].shape[0])

    @property
    def time_s(self) -> np.ndarray:
        """Seconds since sample 0, shape (samples,)."""
        return np.arange(self.samples) * self.sample_time_s

    @property
    def usable(self) -> np.ndarray:
        """Samples that go into the diagnosis."""
        out = np.ones(self.samples, dtype=bool)
        for mask in self.excluded.values():
            out &= ~mask
        return out

    def stretch_bounds(self) -> list[tuple[int, int]]:
        """``[start, stop)`` of every unbroken stretch of usable samples."""
        return runs(self.usable)

    def bounds_had_outliers_been_valid(self) -> list[tuple[int, int]]:
        """:meth:`stretch_bounds` with the dropped gross outliers counted as values: what dropping them broke."""
        if not any(mask.any() for mask in self.outliers.values()):
            return self.stretch_bounds()
        valid = np.ones(self.samples, dtype=bool)
        for key, values in self.signals.items():
            dropped = self.outliers.get(key, np.zeros(values.shape, dtype=bool))
            valid &= np.all(np.isfinite(values) | dropped, axis=1)
        usable = valid
        for reason, mask in self.excluded.items():
            if reason != "missing":
                usable = usable & ~mask
        return runs(usable)

    def stretches(self, *, deviations: bool = True) -> list[Record]:
        """The usable stretches as deviation variables (each one's means removed), or as read if not ``deviations``."""
        out = []
        for a, b in self.stretch_bounds():
            part = {
                key: values[a:b] - (values[a:b].mean(axis=0) if deviations else 0.0)
                for key, values in self.signals.items()
            }
            manual = None if self.manual is None else self.manual[a:b]
            manual = manual if manual is not None and manual.any() else None
            out.append(Record(part["r"], part["u"], part["y"], part.get("dither"), part.get("dv"), manual))
        return out

    @classmethod
    def from_record(
        cls,
        signals: dict[str, np.ndarray],
        *,
        source: str,
        sample_time_s: float,
        start: str = "0 s",
        manual: np.ndarray | None = None,
    ):
        """Data already clean (a bag's window): every sample usable, nothing flagged; ``manual``: the MVs' modes."""
        samples = signals["r"].shape[0]
        missing = ~np.all(np.isfinite(np.hstack(list(signals.values()))), axis=1)
        columns = {key: tuple(f"{key}{j + 1}" for j in range(values.shape[1])) for key, values in signals.items()}
        return cls(
            source,
            start,
            sample_time_s,
            signals,
            columns,
            {"missing": missing},
            np.zeros((samples, signals["u"].shape[1]), dtype=bool),
            (CleaningStep("samples read", samples, "samples"),),
            manual=None if manual is None or not np.any(manual) else np.asarray(manual, dtype=bool),
        )
