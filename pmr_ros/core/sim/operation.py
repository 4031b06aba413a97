"""The signals of routine operation: operator-like setpoint steps, moving measured disturbances, manual stretches.

Real plants are not step-tested: setpoints change a few times a day, measured
disturbances (feed rate, feed composition) wander, and operators put an MV in
manual and move it by hand.  Each signal here has its own random stream,
seeded from the run's seed and a fixed stream number, independent of the
measurement noise (stream 0), the output disturbance and setpoint phases
(1) and the dither phases (2), so switching one on changes no other signal.

Every generator is stateless in ``k`` for its caller: ``value(k)`` may be asked
in any order and gives the same numbers as a whole ``sequence`` (a channel's
events are drawn in order from its own stream and kept).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .excitation import PrbsGenerator, PrbsSettings

__all__ = [
    "DISTURBANCE_STREAM",
    "MANUAL_STREAM",
    "SETPOINT_STEP_STREAM",
    "SIGNAL_KINDS",
    "DisturbanceSignalSettings",
    "ManualOperator",
    "ManualSettings",
    "RandomSignal",
    "manual_plan",
    "setpoint_generator",
]

SIGNAL_KINDS = ("steps", "walk", "prbs")
"""How a random signal moves (see :class:`RandomSignal`)."""

SETPOINT_STEP_STREAM, DISTURBANCE_STREAM, MANUAL_STREAM = 10, 11, 12
"""Random streams ``[seed, stream, channel]`` of the setpoint steps, the DVs and the operators' manual moves."""

_BLOCK = 4096
"""Samples (walk) or events (steps, prbs) drawn at once when a channel is extended."""


class _Channel:
    """One channel's samples, drawn in order from its own stream and kept (so any query order gives the same)."""

    def __init__(self, kind: str, amplitude: float, mean_interval: float, rng: np.random.Generator) -> None:
        if kind not in SIGNAL_KINDS:
            raise ValueError(f"unknown signal kind {kind!r}; choose one of {', '.join(SIGNAL_KINDS)}")
        self.kind, self.amplitude, self.mean_interval, self.rng = kind, float(amplitude), float(mean_interval), rng
        self.samples = np.zeros(0)
        self._level = 0.0 if kind != "prbs" else float(rng.choice((-1.0, 1.0)))
        self._walk: float | None = None

    def _extend_events(self) -> np.ndarray:
        """The next block of samples of a piecewise-constant channel (steps, prbs)."""
        intervals = np.maximum(1, np.rint(self.rng.exponential(self.mean_interval, _BLOCK))).astype(int)
        levels: np.ndarray
        if self.kind == "steps":
            levels = self.rng.uniform(-1.0, 1.0, _BLOCK)
        else:
            levels = self._level * (-1.0) ** np.arange(1, _BLOCK + 1)
        # the current level holds for the first interval, then each new level for the next one
        held = np.concatenate(([self._level], levels[:-1]))
        self._level = float(levels[-1])
        return np.repeat(held, intervals)

    def _extend_walk(self) -> np.ndarray:
        """The next block of a stationary first-order autoregressive drift with std 1."""
        pole = float(np.exp(-1.0 / self.mean_interval))
        e = self.rng.standard_normal(_BLOCK)
        innovation = np.sqrt(1.0 - pole * pole)
        out = np.empty(_BLOCK)
        x = self._walk
        for k in range(_BLOCK):
            x = float(e[k]) if x is None else pole * x + innovation * float(e[k])  # starts stationary
            out[k] = x
        self._walk = x
        return out

    def values(self, k: np.ndarray) -> np.ndarray:
        """The channel at samples ``k`` [its unit]."""
        k = np.asarray(k, dtype=int)
        needed = int(k.max(initial=-1)) + 1
        while self.samples.size < needed:
            block = self._extend_walk() if self.kind == "walk" else self._extend_events()
            self.samples = np.concatenate((self.samples, block))
        return self.amplitude * self.samples[k]


class RandomSignal:
    """Multichannel random signal around ``nominal``: ``kind`` per channel, each from its own stream.

    * ``steps``: the channel starts at ``nominal`` and after random exponential
      intervals (mean ``mean_interval`` samples, at least 1) jumps to
      ``nominal + amplitude x uniform(-1, 1)``: an operator's setpoint changes,
      a feed rate moved by the upstream unit.
    * ``walk``: ``nominal + amplitude x w(k)``, ``w`` a stationary first-order
      autoregressive drift with unit variance and correlation time
      ``mean_interval`` samples: a feed composition that wanders.
    * ``prbs``: ``nominal +/- amplitude``, switching sign after random
      exponential intervals (a random telegraph signal).

    Parameters
    ----------
    kinds : sequence of str
        One of :data:`SIGNAL_KINDS` per channel.
    amplitude, mean_interval, nominal : array_like, shape (n_channels,)
        Size [unit], mean interval between moves [samples, > 0], centre [unit].
    seed, stream : int
        The channel ``j`` draws from ``numpy.random.default_rng([seed, stream, j])``.

    Examples
    --------
    >>> s = RandomSignal(["steps"], [1.0], [50.0], [0.0], seed=1, stream=10)
    >>> bool(abs(s.sequence(1000)).max() <= 1.0), s.value(0).tolist()
    (True, [0.0])
    """

    def __init__(
        self, kinds: object, amplitude: object, mean_interval: object, nominal: object, *, seed: int, stream: int
    ) -> None:
        kinds = list(np.asarray(kinds, dtype=object).ravel())
        n = len(kinds)
        amplitude = np.broadcast_to(np.asarray(amplitude, dtype=float), (n,))
        interval = np.broadcast_to(np.asarray(mean_interval, dtype=float), (n,))
        if np.any(interval <= 0):
            raise ValueError(f"mean intervals must be > 0 samples, got {interval.tolist()}")
        self.nominal = np.broadcast_to(np.asarray(nominal, dtype=float), (n,)).copy()
        self._channels = [
            _Channel(str(kinds[j]), amplitude[j], interval[j], np.random.default_rng([int(seed), stream, j]))
            for j in range(n)
        ]

    def values(self, k: np.ndarray) -> np.ndarray:
        """Values at the samples ``k`` (any order), shape (len(k), n_channels)."""
        k = np.asarray(k, dtype=int)
        if not self._channels:
            return np.zeros((k.size, 0))
        return self.nominal + np.stack([c.values(k) for c in self._channels], axis=1)

    def value(self, k: int) -> np.ndarray:
        """Values at sample ``k``, shape (n_channels,)."""
        return self.values(np.array([k]))[0]

    def sequence(self, samples: int) -> np.ndarray:
        """Values for samples ``0 .. samples-1``, shape (samples, n_channels)."""
        return self.values(np.arange(samples))


@dataclass(frozen=True)
class DisturbanceSignalSettings:
    """How the simulated measured disturbances move (the ``disturbance_signal`` block).

    Attributes
    ----------
    kind : tuple of str
        One of :data:`SIGNAL_KINDS` per DV.
    amplitude : ndarray, shape (n_disturbances,)
        Size of its moves [DV unit]; 0: it does not move.
    mean_interval_samples : ndarray, shape (n_disturbances,)
        Mean time between its moves (walk: its correlation time) [samples].
    """

    kind: tuple[str, ...] = ()
    amplitude: np.ndarray = field(default_factory=lambda: np.zeros(0))
    mean_interval_samples: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def n_disturbances(self) -> int:
        """DVs described."""
        return len(self.kind)

    def generator(self, seed: int) -> RandomSignal:
        """The DVs of run ``seed`` (deviation from nominal, starting at 0 unless a prbs)."""
        return RandomSignal(
            self.kind,
            self.amplitude,
            self.mean_interval_samples,
            np.zeros(self.n_disturbances),
            seed=seed,
            stream=DISTURBANCE_STREAM,
        )


@dataclass(frozen=True)
class ManualSettings:
    """Stretches where an MV's controller is off and an operator moves it (``run.manual_stretches``).

    Attributes
    ----------
    stretches : tuple of (int, int, int)
        ``(start, length, input index)`` [samples, samples, 0-based].
    move_amplitude : ndarray, shape (n_inputs,)
        Largest operator move from the MV's value at the stretch's start [input unit].
    moves : int
        Operator moves per stretch, at random samples inside it.
    """

    stretches: tuple[tuple[int, int, int], ...] = ()
    move_amplitude: np.ndarray = field(default_factory=lambda: np.zeros(0))
    moves: int = 3

    @property
    def active(self) -> bool:
        """Whether any stretch is configured."""
        return bool(self.stretches)

    @property
    def end(self) -> int:
        """The sample after the last stretch ends (0 without stretches) [samples]."""
        return max((start + length for start, length, _ in self.stretches), default=0)


def manual_plan(settings: ManualSettings, n_inputs: int, samples: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Where each MV is in manual and the operator's offsets from its value at the stretch's start.

    The operator makes ``settings.moves`` moves per stretch, at random samples
    inside it (the first sample of a stretch holds the MV where it was), each
    to ``move_amplitude x uniform(-1, 1)`` from the value at the start.

    Parameters
    ----------
    settings : ManualSettings
    n_inputs, samples : int
    seed : int
        Stream ``[seed, MANUAL_STREAM]``.

    Returns
    -------
    manual : ndarray of bool, shape (samples, n_inputs)
        True inside a stretch.
    offset : ndarray, shape (samples, n_inputs)
        The operator's offset [input unit]; 0 outside the stretches.
    """
    rng = np.random.default_rng([int(seed), MANUAL_STREAM])
    manual = np.zeros((samples, n_inputs), dtype=bool)
    offset = np.zeros((samples, n_inputs))
    amplitude = np.broadcast_to(np.asarray(settings.move_amplitude, dtype=float), (n_inputs,))
    for start, length, j in settings.stretches:
        # draws in a fixed order per stretch, whether or not it fits in the run
        times = np.sort(rng.integers(1, max(length, 2), size=settings.moves)) if length > 1 else np.zeros(0, int)
        levels = amplitude[j] * rng.uniform(-1.0, 1.0, size=times.size)
        end = min(start + length, samples)
        if start >= samples:
            continue
        manual[start:end, j] = True
        path = np.zeros(length)
        for t, level in zip(times.tolist(), levels.tolist(), strict=True):
            path[t:] = level
        offset[start:end, j] = path[: end - start]
    return manual, offset


class ManualOperator:
    """The operators of the manual stretches, sample by sample: the MV values they set by hand.

    The batch loop and the ``mpc_controller`` node both ask it at each sample, so
    both give the controller the same operator's values.  A stretch starts from
    the MV's value of the sample before it (the controller's last applied input)
    and follows :func:`manual_plan`'s moves, within ``u_min .. u_max``.

    Parameters
    ----------
    settings : ManualSettings
    n_inputs : int
    seed : int
        The run's seed (stream ``[seed, MANUAL_STREAM]``).
    u_min, u_max : array_like, shape (n_inputs,)
        The MVs' limits [input unit].

    Examples
    --------
    >>> op = ManualOperator(ManualSettings(((2, 3, 0),), np.array([0.0]), 1), 1, 1, u_min=[-1.0], u_max=[1.0])
    >>> op.inputs(1, np.array([0.4])) is None, op.inputs(2, np.array([0.4])).tolist()
    (True, [0.4])
    """

    def __init__(self, settings: ManualSettings, n_inputs: int, seed: int, *, u_min: object, u_max: object) -> None:
        # the plan up to the last stretch's end: a stretch's moves do not depend on the run's length
        self.manual, self._offset = manual_plan(settings, n_inputs, settings.end, seed)
        self._limits = (np.asarray(u_min, dtype=float), np.asarray(u_max, dtype=float))
        self._base = np.zeros(n_inputs)  # each MV's value where its stretch began

    def in_manual(self, k: int) -> np.ndarray:
        """Which MVs are in manual at sample ``k`` (bool, shape (n_inputs,))."""
        if k >= self.manual.shape[0]:
            return np.zeros(self.manual.shape[1], dtype=bool)
        return self.manual[k]

    def inputs(self, k: int, previous: np.ndarray) -> np.ndarray | None:
        """The operator's MV values at sample ``k`` (NaN where the controller is on), None when all are on.

        Parameters
        ----------
        k : int
            The sample; asked in increasing order.
        previous : ndarray, shape (n_inputs,)
            The inputs applied at sample ``k - 1`` (zeros at ``k = 0``) [input unit].
        """
        now = self.in_manual(k)
        if not now.any():
            return None
        starting = now & (~self.manual[k - 1] if k else True)
        self._base = np.where(starting, previous, self._base)
        value = np.clip(self._base + self._offset[k], *self._limits)
        return np.where(now, value, np.nan)


class _HeldSetpoints:
    """Setpoints of which only some channels move: the others stay at nominal (zone CVs)."""

    def __init__(self, source: RandomSignal | PrbsGenerator, nominal: np.ndarray, moving: np.ndarray) -> None:
        self._source, self._nominal, self._moving = source, nominal, moving

    def values(self, k: np.ndarray) -> np.ndarray:
        """Values at the samples ``k``, shape (len(k), n_channels)."""
        return np.where(self._moving, self._source.values(np.asarray(k)), self._nominal)

    def value(self, k: int) -> np.ndarray:
        """Values at sample ``k``, shape (n_channels,)."""
        return self.values(np.array([k]))[0]

    def sequence(self, samples: int) -> np.ndarray:
        """Values for samples ``0 .. samples-1``, shape (samples, n_channels)."""
        return self.values(np.arange(samples))


def setpoint_generator(
    prbs: PrbsSettings, seed: int, *, moving: np.ndarray | None = None
) -> PrbsGenerator | RandomSignal | _HeldSetpoints:
    """The setpoints of run ``seed``: the PRBS or operator-like steps (``prbs.mode``), on the moving CVs only.

    Parameters
    ----------
    prbs : PrbsSettings
    seed : int
    moving : ndarray of bool, shape (n_outputs,), optional
        The setpoint CVs; a zone CV's setpoint stays at its ``nominal`` (it is
        not tracked).  None: every CV moves.

    Returns
    -------
    object with ``value(k)``, ``values(k)`` and ``sequence(samples)``
        Without zones in PRBS mode the :class:`PrbsGenerator` itself (the same numbers as ever).
    """
    nominal = np.asarray(prbs.nominal, dtype=float)
    source: PrbsGenerator | RandomSignal
    if prbs.mode == "steps":
        amplitude = prbs.amplitude if prbs.step_amplitude is None else prbs.step_amplitude
        kinds = ["steps"] * nominal.size
        interval = prbs.step_interval_samples
        source = RandomSignal(kinds, amplitude, interval, nominal, seed=seed, stream=SETPOINT_STEP_STREAM)
    else:
        source = PrbsGenerator(prbs, seed)
    if moving is None or bool(np.all(moving)):
        return source
    return _HeldSetpoints(source, nominal, np.asarray(moving, dtype=bool))
