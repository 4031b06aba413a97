"""The bounded watch over an in-process run: progress toward its end, or one line naming what is stuck.

Progress is only what brings the run nearer its end, and every measure of it is
bounded: the plant's newest sample (at most the last), the newest sample the
diagnostician took on each signal and the samples the run's listener recorded
(both counted up to the run's last sample, so a producer that keeps publishing
after the run, or repeats old stamps, adds nothing), and the final verdicts and
estimates arriving.  A diagnostician merely busy, or still receiving messages,
is no progress: it only lengthens the silence allowed to that of one diagnosis.
So every wait ends: after at most ``stall_timeout_s`` without progress (
``verdict_timeout_s`` while a diagnosis runs), and a real-time run's sampling
also within a wall-clock bound from its length and pace.  No rclpy here: the
node set hands the nodes over and calls :meth:`RunWatch.check` as it spins.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from ..contract.topics import topic

__all__ = ["REAL_TIME_ALLOWANCE_S", "RunLimits", "RunStalled", "RunWatch"]

REAL_TIME_ALLOWANCE_S = 0.1
"""How much longer than its period each sample of a real-time run may take before the run is overdue [s].
The node set cannot keep every pace: asked for 400 samples/s, its one executor thread made 86 samples/s
alone on the 2 cores (11.6 ms a sample) and took up to 63 ms a sample under two busy loops and a second
run (600 samples in 2.6-37.9 s over 93 runs, at loads up to 10); 0.1 s leaves over half as much again."""


class RunStalled(RuntimeError):
    """The run stopped going toward its end; the message says which node or topic and which sample."""


@dataclass(frozen=True)
class RunLimits:
    """How long each part of a run may take.

    Attributes
    ----------
    samples : int
        The run's length [samples].
    stall_timeout_s : float
        The longest time without progress [s].
    verdict_timeout_s : float
        The longest time without progress while the diagnostician diagnoses (its worker busy) [s]:
        a diagnosis with the control impact outlasted 30 s under load.
    start_timeout_s : float
        How long the plant may take to publish its first sample (it waits for its peers) [s].
    real_time_rate_hz : float
        The real-time pace [samples/s]; 0 in lockstep, which has no wall-clock bound.
    """

    samples: int
    stall_timeout_s: float
    verdict_timeout_s: float
    start_timeout_s: float
    real_time_rate_hz: float = 0.0

    @property
    def sampling_bound_s(self) -> float | None:
        """From the first sample, when a real-time run must have sampled its last [s]; None in lockstep."""
        if self.real_time_rate_hz <= 0:
            return None
        return self.samples * (1.0 / self.real_time_rate_hz + REAL_TIME_ALLOWANCE_S) + self.stall_timeout_s


class RunWatch:
    """Watches a run of ``limits.samples`` samples; :meth:`check` raises :class:`RunStalled` when it is stuck.

    Parameters
    ----------
    plant : object
        With ``sample`` (newest published, -1 before the first), ``finished`` and, in lockstep, ``gate``
        (:class:`~pmr_ros.ros.flow.ProgressGate`, naming the consumers that hold it back).
    diagnostician : object
        With ``aligner.newest`` (signal -> newest sample taken), ``busy``, ``run_complete`` and ``finish_run()``.
    listener : object
        With ``final`` (the final verdicts or None), ``final_has_verdict``, ``estimates`` and ``recorded()``
        (signal -> samples recorded, empty without recording).
    limits : RunLimits
    labels : mapping, optional
        Signal -> how a line names it (``y on /pmr/measured_output``); ``diagnostics`` and ``estimates`` -> their
        topics' names as resolved in the run's namespace.
    others : sequence, optional
        Further nodes whose ``done`` the run waits for.
    """

    def __init__(
        self,
        plant: Any,
        diagnostician: Any,
        listener: Any,
        limits: RunLimits,
        *,
        labels: dict[str, str] | None = None,
        others: Sequence[Any] = (),
    ) -> None:
        self.plant, self.diagnostician, self.listener, self.limits = plant, diagnostician, listener, limits
        self.labels = labels or {}
        self.others = list(others)
        self.created = time.monotonic()
        self.started: float | None = None  # when the first sample went out
        self.last_progress = self.created
        self._taken: dict[str, int] = {}  # signal -> the diagnostician's newest sample taken, at most the last
        self._progress: tuple = ()

    @property
    def final_sample(self) -> int:
        """The run's last sample."""
        return self.limits.samples - 1

    def check(self, now: float | None = None) -> None:
        """Note progress; raise :class:`RunStalled` (one line) when the run is stuck or overdue."""
        plant, d = self.plant, self.diagnostician
        if plant.finished and not d.run_complete:
            d.finish_run()  # its silence watchdog stops: no stale warning after the run
        now = time.monotonic() if now is None else now
        if self.started is None and plant.sample >= 0:
            self.started = now
        progress = self._measure()
        if progress != self._progress:
            self._progress, self.last_progress = progress, now
        problem = self._overdue(now) or self._stalled(now)
        if problem:
            raise RunStalled(problem)

    def _measure(self) -> tuple:
        """Every measure of progress, each bounded by the run's end (high-water marks)."""
        for signal, k in self.diagnostician.aligner.newest.items():
            # a new aligner (a new system) starts again from None: the mark stays; later stamps count up to the end
            if k is not None:
                self._taken[signal] = max(self._taken.get(signal, -1), min(k, self.final_sample))
        recorded = {s: min(n, self.limits.samples) for s, n in self.listener.recorded().items()}
        listener = self.listener
        return (
            self.plant.sample,
            tuple(sorted(self._taken.items())),
            tuple(sorted(recorded.items())),
            listener.final is not None,
            listener.estimates is not None,
        )

    def _overdue(self, now: float) -> str | None:
        """The start, and a real-time run's sampling, are bounded in wall time."""
        plant, limits = self.plant, self.limits
        if self.started is None and now - self.created > max(limits.start_timeout_s, limits.stall_timeout_s):
            return (
                f"the node set never started: the plant published no sample within "
                f"{max(limits.start_timeout_s, limits.stall_timeout_s):g} s{self._held_back()}"
            )
        bound = limits.sampling_bound_s
        if bound is not None and self.started is not None and not plant.finished and now - self.started > bound:
            return (
                f"the real-time run did not end within {bound:.3g} s ({limits.samples} samples at "
                f"{limits.real_time_rate_hz:g} samples/s): the plant is at sample {plant.sample}"
            )
        return None

    def _stalled(self, now: float) -> str | None:
        """No progress for longer than allowed: which node or topic, at which sample."""
        if self.started is None:
            return None  # bounded by _overdue
        silent = now - self.last_progress
        allowed = self.limits.stall_timeout_s
        busy = self.diagnostician.busy
        if busy:
            allowed = max(allowed, self.limits.verdict_timeout_s)
        if silent <= allowed:
            return None
        worker = ", its diagnostician's worker still busy" if busy else ""
        return f"the node set stalled ({silent:.0f} s without progress{worker}): {self.stuck()}"

    def stuck(self) -> str:
        """What the run waits for now, first thing first."""
        plant, listener, last = self.plant, self.listener, self.final_sample
        if not plant.finished:
            return f"the plant is at sample {plant.sample} of {self.limits.samples}{self._held_back()}"
        lagging = [
            f"{self.labels.get(s, s)} at sample {self._taken.get(s, -1)}"
            for s in self.diagnostician.aligner.newest
            if self._taken.get(s, -1) < last
        ]
        if lagging:
            return f"after the plant's last sample ({last}) the diagnostician has taken {', '.join(lagging)}"
        missing = [
            f"{self.labels.get(s, s)} ({n} of {self.limits.samples} samples)"
            for s, n in listener.recorded().items()
            if n < self.limits.samples
        ]
        if missing:
            return f"the run's listener has not recorded every sample: {', '.join(missing)}"
        if listener.final is None:
            verdicts = f"no final verdicts (for sample {last}) on {self._topic('diagnostics')}"
            return f"{verdicts}; the diagnostician took every sample"
        if listener.final_has_verdict and listener.estimates is None:
            return f"final verdicts, but no estimates for sample {last} on {self._topic('estimates')}"
        waiting = [_name(n) for n in self.others if not n.done]
        return f"waiting for {', '.join(waiting) or 'nothing'} to be done"

    def _topic(self, key: str) -> str:
        """How a line names the contract topic ``key``: its label, else its name as the contract has it, absolute."""
        return self.labels.get(key) or "/" + topic(key).name.lstrip("/")

    def _held_back(self) -> str:
        """A lockstep plant held back by its consumers: whom it waits for."""
        gate = getattr(self.plant, "gate", None)
        behind = gate.behind() if gate is not None and self.limits.real_time_rate_hz <= 0 else {}
        return f", held back by {', '.join(behind)}" if behind else ""

    @property
    def wall_time_s(self) -> float:
        """From the first published sample to now [s]."""
        return time.monotonic() - (self.started or time.monotonic())


def _name(node: Any) -> str:
    get_name = getattr(node, "get_name", None)
    return get_name() if callable(get_name) else type(node).__name__
