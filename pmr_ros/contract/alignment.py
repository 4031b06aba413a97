"""Aligning setpoints r, inputs u and outputs y by sample, from messages that may misbehave.

Messages carry their sample time as a stamp; sample k has the stamp k * Ts, so
the index is ``k = round(stamp / Ts)``.  A sample is *complete* once r(k), u(k)
and y(k) have all arrived, in whatever order: a signal whose messages come
late (a publisher discovered late, whose transient-local backlog arrives after
the other signals moved on) still completes the samples the others left
pending.  A partial sample is given up only when it can no longer complete
(a signal it lacks has moved past it) or, oldest first, when more partial
samples are held than the memory bound allows.

The window is the newest ``capacity`` complete samples.  The PMR's spectra and
the model's element outputs assume evenly spaced, gap-free records, so a
missing or rejected sample splits the window into unbroken *stretches*; the
diagnosis pools the Welch segments of every stretch
(:func:`pmr_ros.core.pmr.diagnosis.diagnose_stretches`).

Rejected, with a reason naming the signal, its topic and the value:
non-finite values, a wrong number of values or wrong channel names, stamps off
the sample grid, and duplicated or out-of-order stamps (each signal's index
must strictly increase; the first message of a sample wins).

No rclpy here: this module is plain Python/numpy and is tested without ROS.
"""

from __future__ import annotations

import bisect
import copy
from collections import deque
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..core.records import Record
from .samples import (
    BAD_STAMP,
    DUPLICATED,
    GRID_TOLERANCE,
    OFF_GRID,
    OUT_OF_ORDER,
    AddResult,
    sample_index,
    signal_problem,
)

__all__ = ["MANUAL", "AlignedStretch", "SampleAligner", "manual_marks"]

SIGNALS = ("r", "u", "y")
"""Signals the diagnostician aligns: setpoints, inputs, outputs."""

MANUAL = "manual"
"""The controllers' modes, read from the u messages' ``effort`` (1.0 where an MV's controller is off)."""

OPTIONAL_SIGNALS = ("dv", MANUAL)
"""Signals aligned when the aligner is given their channel names: the measured disturbances, the modes."""


def manual_marks(effort: Sequence[float] | np.ndarray, width: int) -> np.ndarray:
    """A u message's mode marks as offered to the aligner: ``effort``, or zeros (every controller on) when empty."""
    marks = np.asarray(effort, dtype=float)
    return np.zeros(width) if marks.size == 0 else marks


def _record(rows: Mapping[str, list], a: int, b: int) -> Record:
    """Rows ``a:b`` of every aligned signal as a :class:`Record` (``dv``, ``manual`` when aligned and any is off)."""
    arrays = {s: np.array(rows[s][a:b]) for s in rows}
    off = arrays[MANUAL] > 0.5 if MANUAL in arrays else None
    manual = off if off is not None and off.any() else None
    return Record(arrays["r"], arrays["u"], arrays["y"], dv=arrays.get("dv"), manual=manual)


@dataclass(frozen=True)
class AlignedStretch:
    """An unbroken stretch of complete samples ``first .. first + samples - 1``: a :class:`Record` placed in time.

    Attributes
    ----------
    first : int
        Index of its first sample.
    record : Record
        Its r, u, y (and dv when aligned), one row per sample (no dither: the aligner holds none).
    """

    first: int
    record: Record

    @property
    def r(self) -> np.ndarray:
        """Setpoints, one row per sample."""
        return self.record.r

    @property
    def u(self) -> np.ndarray:
        """Inputs, one row per sample."""
        return self.record.u

    @property
    def y(self) -> np.ndarray:
        """Outputs, one row per sample."""
        return self.record.y

    @property
    def samples(self) -> int:
        """Samples in the stretch."""
        return self.record.samples

    @property
    def last(self) -> int:
        """Index of its last sample."""
        return self.first + self.samples - 1


PENDING_MARGIN = 16
"""Partial samples held beyond ``capacity + 4 max_lag_samples`` (see :attr:`SampleAligner.pending_limit`)."""


class SampleAligner:
    """Assembles complete samples of r, u and y (and DVs) and keeps the newest ``capacity`` of them, in stretches.

    Parameters
    ----------
    sample_time_s : float
        Ts [s].
    channel_names : dict
        Signal (``r``, ``u``, ``y``; ``dv`` when the measured disturbances are
        aligned too: a sample then needs them to be complete; ``manual``, the
        input names, when the modes marked on u are aligned) to its channel names.
    labels : dict
        Signal to how warnings name it, e.g. ``"y on /pmr/measured_output"``.
    capacity : int
        Complete samples kept (the diagnosis window).
    max_lag_samples : int
        A signal this many samples behind the newest one counts as stopped.

    Attributes
    ----------
    stretch_first, stretch_last : int or None
        First and last sample of the newest unbroken stretch.
    gaps : int
        Times a new stretch began after a gap.
    rejected : dict
        Signal -> messages rejected.
    given_up : int
        Partial samples given up because more were held than :attr:`pending_limit`.
    """

    def __init__(
        self,
        sample_time_s: float,
        channel_names: Mapping[str, Sequence[str]],
        labels: Mapping[str, str],
        capacity: int,
        max_lag_samples: int,
    ) -> None:
        self.sample_time_s = float(sample_time_s)
        self.signals = (*SIGNALS, *(s for s in OPTIONAL_SIGNALS if s in channel_names))
        self.channel_names = {s: tuple(channel_names[s]) for s in self.signals}
        # the modes come with u: their problems are named after u's topic
        self.labels = {MANUAL: f"the mode marks (effort) of {labels.get('u', 'u')}", **labels}
        self.capacity = int(capacity)
        self.max_lag_samples = int(max_lag_samples)
        self.newest: dict[str, int | None] = {s: None for s in self.signals}
        self.rejected: dict[str, int] = {s: 0 for s in self.signals}
        self.gaps = 0
        self.given_up = 0
        self._pending: dict[int, dict[str, np.ndarray]] = {}
        self._broken: dict[int, frozenset[str]] = {}
        self._index: deque[int] = deque(maxlen=self.capacity)
        self._rows: dict[str, deque] = {s: deque(maxlen=self.capacity) for s in self.signals}
        self.stretch_first: int | None = None
        self.stretch_last: int | None = None

    # -- state -------------------------------------------------------------
    @property
    def stretch_length(self) -> int:
        """Complete samples in the newest unbroken stretch (not capped at capacity)."""
        if self.stretch_first is None or self.stretch_last is None:  # both None together
            return 0
        return self.stretch_last - self.stretch_first + 1

    @property
    def held(self) -> int:
        """Complete samples held (at most ``capacity``), in every stretch."""
        return len(self._index)

    @property
    def pending_limit(self) -> int:
        """Most partial samples held: the window, four times the stopped-signal lag and a margin.

        A signal whose backlog arrives late completes every sample it finds
        still pending; beyond this bound the oldest partial samples are given
        up, so memory stays bounded whatever the arrival order.
        """
        return self.capacity + 4 * self.max_lag_samples + PENDING_MARGIN

    def window(self, samples: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """The newest ``samples`` (at most) of the newest unbroken stretch: ``r, u, y, first_index``.

        Raises
        ------
        ValueError
            No sample is complete yet (there is no stretch).
        """
        if self.stretch_last is None:
            raise ValueError("no complete sample yet: the stretch is empty")
        take = min(samples, len(self._index), self.stretch_length)
        out = [np.array(list(self._rows[s])[len(self._rows[s]) - take :]) for s in self.signals]
        return out[0], out[1], out[2], self.stretch_last - take + 1

    def stretches(self, samples: int) -> list[AlignedStretch]:
        """The newest ``samples`` (at most) complete samples, split into unbroken stretches, oldest first."""
        take = min(samples, len(self._index))
        if take <= 0:
            return []
        index = np.fromiter(list(self._index)[len(self._index) - take :], dtype=np.int64, count=take)
        rows = {s: list(self._rows[s])[len(self._rows[s]) - take :] for s in self.signals}
        cuts = [0, *(np.flatnonzero(np.diff(index) != 1) + 1).tolist(), take]
        return [AlignedStretch(int(index[a]), _record(rows, a, b)) for a, b in zip(cuts[:-1], cuts[1:], strict=True)]

    def snapshot(self) -> SampleAligner:
        """A copy of the aligned samples that later messages do not change.

        For diagnosing on another thread while messages keep coming (the live
        diagnostician): the copy answers ``window``, ``lagging``,
        ``stretch_*`` and ``gaps`` as this aligner does now.  The sample
        arrays, never modified once stored, are shared; the containers are not.
        """
        twin = copy.copy(self)
        twin.newest = dict(self.newest)
        twin.rejected = dict(self.rejected)
        twin._pending = {}
        twin._broken = {}
        twin._index = deque(self._index, maxlen=self.capacity)
        twin._rows = {s: deque(self._rows[s], maxlen=self.capacity) for s in self.signals}
        return twin

    def value(self, signal: str, k: int) -> np.ndarray | None:
        """The values of ``signal`` taken for sample ``k``, if still held (waiting, or in the stretch).

        For telling a repeated message from an inconsistent one (the same
        stamp with other values: two publishers on one topic).
        """
        waiting = self._pending.get(k, {}).get(signal)
        if waiting is not None:
            return waiting
        if not self._index or not self._index[0] <= k <= self._index[-1]:
            return None
        if self.stretch_first is not None and self.stretch_last is not None and k >= self.stretch_first:
            return self._rows[signal][k - self.stretch_last - 1]  # in the newest stretch: counted from the end
        index = list(self._index)  # an older stretch: the indices are sorted, with gaps
        pos = bisect.bisect_left(index, k)
        return self._rows[signal][pos] if index[pos] == k else None

    def restart(self) -> None:
        """Begin a new stretch after a break the stamps do not show (samples that cannot be trusted).

        Every complete sample held is forgotten, in every stretch (the window
        may already mix two publishers' samples); what comes next starts a new
        stretch.
        """
        if self.stretch_last is not None:
            self.gaps += 1
        self._index.clear()
        for s in self.signals:
            self._rows[s].clear()
        self.stretch_first = self.stretch_last = None

    def resize(self, capacity: int) -> None:
        """Keep up to ``capacity`` samples from now on (newest first kept)."""
        self.capacity = int(capacity)
        self._index = deque(self._index, maxlen=self.capacity)
        for s in self.signals:
            self._rows[s] = deque(self._rows[s], maxlen=self.capacity)

    def lagging(self) -> str | None:
        """Why the data are stale (a signal stopped or never came), or None."""
        seen = [k for k in self.newest.values() if k is not None]
        if not seen:
            return None
        head = max(seen)
        for s in self.signals:
            k = self.newest[s]
            if k is None and head + 1 > self.max_lag_samples:
                return f"no {self.labels[s]} received while the other signals reached sample {head}"
            if k is not None and head - k > self.max_lag_samples:
                return f"{self.labels[s]} stopped at sample {k} while the other signals reached sample {head}"
        return None

    # -- input -------------------------------------------------------------
    def _problem(
        self, signal: str, stamp_s: float, names: Sequence[str], values: Sequence[float] | np.ndarray
    ) -> tuple[int, tuple[str, str] | None]:
        """The message's sample index and why it is rejected (``(kind, text)``), or None."""
        label = self.labels[signal]
        problem = signal_problem(label, names, values, self.channel_names[signal])
        if problem is not None:
            return 0, problem
        if not np.isfinite(stamp_s):
            return 0, (BAD_STAMP, f"{label}: stamp {stamp_s!r} s is not finite; message dropped")
        k, offset = sample_index(stamp_s, self.sample_time_s)
        if abs(offset) > GRID_TOLERANCE:
            return k, (
                OFF_GRID,
                f"{label}: stamp {stamp_s:.9g} s is {offset:+.2f} samples off the sample grid (Ts = "
                f"{self.sample_time_s:g} s); message dropped",
            )
        last = self.newest[signal]
        if last is not None and k <= last:
            kind = DUPLICATED if k == last else OUT_OF_ORDER
            return k, (kind, f"{label}: {kind} stamp {stamp_s:.9g} s (sample {k}, newest is {last}); message dropped")
        return k, None

    def add(self, signal: str, stamp_s: float, names: Sequence[str], values: Sequence[float] | np.ndarray) -> AddResult:
        """Offer one message of ``signal``; returns what happened, never raises on bad data."""
        k, problem = self._problem(signal, stamp_s, names, values)
        if problem is not None:
            self.rejected[signal] += 1
            return AddResult(False, [problem[1]], rejected_as=problem[0])
        label, last = self.labels[signal], self.newest[signal]
        result = AddResult(True)
        if last is not None and k > last + 1:
            result.warnings.append(f"{label}: samples {last + 1}..{k - 1} missing (gap of {k - last - 1})")
        self.newest[signal] = k
        self._forget_passed(signal, last, k)
        if self.stretch_last is not None and k <= self.stretch_last:
            # Another signal already completed a later sample: this one cannot join the stretch.
            result.warnings.append(
                f"{label}: sample {k} arrived after sample {self.stretch_last} was complete; dropped"
            )
            return result
        entry = self._pending.setdefault(k, {})
        entry[signal] = np.array(values, dtype=float)  # a copy: a view would keep the message's buffer alive
        if len(entry) == len(self.signals):
            self._complete(k, result)
        elif len(self._pending) > self.pending_limit:
            self._give_up_oldest(result)
        return result

    def _forget_passed(self, signal: str, last: int | None, k: int) -> None:
        """Give up the partial samples before ``k`` that lack ``signal``: it moved past them."""
        if last is not None and k - last - 1 <= len(self._pending):
            candidates: list[int] = [j for j in range(last + 1, k) if j in self._pending]
        else:
            candidates = [j for j in self._pending if j < k]
        for j in candidates:
            entry = self._pending[j]
            if signal not in entry:
                self._broken[j] = frozenset(self.signals) - entry.keys()
                del self._pending[j]

    def _give_up_oldest(self, result: AddResult) -> None:
        """More partial samples than :attr:`pending_limit`: give up the oldest quarter."""
        keep = (3 * self.pending_limit) // 4
        doomed = sorted(self._pending)[: len(self._pending) - keep]
        for j in doomed:
            self._broken[j] = frozenset(self.signals) - self._pending.pop(j).keys()
        for j in sorted(self._broken)[: max(0, len(self._broken) - self.pending_limit)]:
            del self._broken[j]
        self.given_up += len(doomed)
        result.warnings.append(
            f"more than {self.pending_limit} partial samples held: samples {doomed[0]}..{doomed[-1]} given up "
            f"({self._missing_between(doomed[0], doomed[-1] + 1)})"
        )

    def _complete(self, k: int, result: AddResult) -> None:
        entry = self._pending.pop(k)
        if self.stretch_last is not None and k != self.stretch_last + 1:
            self.gaps += 1
            missing = self._missing_between(self.stretch_last + 1, k)
            result.warnings.append(
                f"samples {self.stretch_last + 1}..{k - 1} incomplete ({missing}): a new stretch starts at sample "
                f"{k} after {self.stretch_length} samples"
            )
            self.stretch_first = None
        for old in [j for j in self._pending if j < k]:
            self._broken[old] = frozenset(self.signals) - self._pending.pop(old).keys()
        self._broken = {j: m for j, m in self._broken.items() if j > k}
        if self.stretch_first is None:
            self.stretch_first = k
        self.stretch_last = k
        self._index.append(k)
        for s in self.signals:
            self._rows[s].append(entry[s])
        result.completed.append(k)

    def _missing_between(self, first: int, last_exclusive: int) -> str:
        """Which signals samples ``first .. last_exclusive - 1`` lacked."""
        known = [m for j, m in self._broken.items() if first <= j < last_exclusive]
        missing: set[str] = set().union(*known)
        if len(known) < last_exclusive - first:  # samples no signal held at all
            missing |= {s for s in self.signals if self.newest[s] is not None}
        return "missing " + ", ".join(s for s in self.signals if s in missing) if missing else "rejected"
