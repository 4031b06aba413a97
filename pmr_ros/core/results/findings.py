"""What one method found about one element of the model: the typed, frozen result values.

:class:`ElementModel` is the controller model's element the plant is compared
with; :class:`ClassicResult` the paper's Table 1 diagnosis (gain ratio M(0),
time-constant index, delay); :class:`ParametricResult` the fitted dK %, dtau %,
dD with intervals and calibrated verdicts; :class:`ImpactResult` what a
mismatch does to control; :class:`DataQuality` how far the data can be
trusted.  Their flat forms (JSON, /diagnostics KeyValues, estimates, CSV) are
made by :mod:`pmr_ros.core.results.codec`, nowhere else.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import ClassVar

__all__ = [
    "KINDS",
    "PROPERTIES",
    "VERDICTS",
    "ClassicResult",
    "DataQuality",
    "ElementModel",
    "ImpactResult",
    "Interval",
    "ParametricResult",
]

VERDICTS = ("ok", "mismatch", "inconclusive")
"""An element's (and a parameter's) verdict: no mismatch, mismatch, or the data cannot tell."""

PROPERTIES = ("gain", "time_constant", "delay", "interaction")
"""The properties of an element a mismatch is found in (``interaction``: an unmodeled one in an empty cell)."""

KINDS = ("foptd", "integrating", "none", "tf", "step_response")
"""Element kinds of a model (:class:`ElementModel.kind`); ``none`` is an empty cell."""


@dataclass(frozen=True)
class ElementModel:
    """The controller model's element ``Ghat_ik`` the diagnosis compares the plant with.

    Attributes
    ----------
    kind : str
        One of :data:`KINDS`: ``foptd`` K exp(-theta s)/(tau s + 1), ``integrating``
        K exp(-theta s)/s, ``none`` an empty cell (no model; gain 0), ``tf`` a
        rational transfer function with dead time, ``step_response`` a sampled
        step-response curve.
    gain : float
        K [output unit / input unit; per time unit when integrating]; the
        steady-state gain (ramp rate) of a ``tf`` or ``step_response`` element.
    time_constant : float or None
        tau [time unit]; None unless ``foptd``.
    delay_samples : int
        theta / Ts [samples].
    """

    kind: str
    gain: float
    time_constant: float | None
    delay_samples: int


@dataclass(frozen=True)
class ClassicResult:
    """The paper's Table 1 diagnosis of one element.

    An ``integrating`` element has no time constant (``tau_index`` None).  The
    classic method does not test empty cells (model ``none``): those have no
    classic result.

    Attributes
    ----------
    gain_ratio : float
        ``M(0) = K / Khat``.
    tau_index : float or None
        ``-100 x`` the slope of ``M(w)/M(0)`` on ``(0, tau_band]`` [1/(rad/sample)];
        positive when the plant is slower than the model.  None unless ``foptd``.
    delay_mismatch_samples : int
        ``D - Dhat`` [samples].
    gain_mismatch, tau_mismatch, delay_mismatch : bool
        Beyond the configured thresholds.
    reasons : tuple of str
        Why the element's numbers cannot be trusted (a delay at the search
        limit); any reason makes the verdict ``inconclusive``.
    """

    gain_ratio: float
    tau_index: float | None
    delay_mismatch_samples: int
    gain_mismatch: bool
    tau_mismatch: bool
    delay_mismatch: bool
    reasons: tuple[str, ...] = ()

    NUMBERS: ClassVar[tuple[str, ...]] = ("gain_ratio", "tau_index", "delay_mismatch_samples")
    """The numeric fields (for plotting topics and tables)."""

    @property
    def mismatches(self) -> tuple[str, ...]:
        """The properties (of :data:`PROPERTIES`) found mismatched."""
        flags = (self.gain_mismatch, self.tau_mismatch, self.delay_mismatch)
        return tuple(p for p, flag in zip(PROPERTIES, flags, strict=False) if flag)

    @property
    def verdict(self) -> str:
        """``inconclusive`` with reasons, else ``mismatch`` if any property is off, else ``ok``."""
        if self.reasons:
            return "inconclusive"
        return "mismatch" if self.mismatches else "ok"

    @property
    def gain_direction(self) -> str:
        """``higher``/``lower`` plant gain than the model's, or ``ok``."""
        if not self.gain_mismatch:
            return "ok"
        return "higher" if self.gain_ratio > 1 else "lower"

    @property
    def tau_direction(self) -> str:
        """``larger``/``smaller`` plant time constant than the model's, or ``ok``."""
        if not self.tau_mismatch or self.tau_index is None:
            return "ok"
        return "larger" if self.tau_index > 0 else "smaller"

    def summary(self) -> str:
        """One line for people: ``gain +15 %, τ larger (index +20), delay +2 samples``."""
        gain = f"gain {100 * (self.gain_ratio - 1):+.0f} %" if self.gain_mismatch else "gain ok"
        parts = [gain]
        if self.tau_index is not None:
            parts.append(f"τ {self.tau_direction} (index {self.tau_index:+.0f})" if self.tau_mismatch else "τ ok")
        parts.append(f"delay {self.delay_mismatch_samples:+d} samples" if self.delay_mismatch else "delay ok")
        return _with_reasons(", ".join(parts), self.reasons)


def _with_reasons(text: str, reasons: tuple[str, ...]) -> str:
    return f"{text} (inconclusive: {'; '.join(reasons)})" if reasons else text


Interval = tuple[float, float]


@dataclass(frozen=True)
class ParametricResult:
    """The parametric (plant-model ratio fit) diagnosis of one element.

    The plant element is modelled as ``rho Ghat(s alpha) exp(-dD s)``: the
    model's gain times rho, its dynamics alpha times slower, its delay dD
    samples longer.  For a FOPTD element ``alpha - 1`` is the relative change
    of its time constant; for a ``tf`` or ``step_response`` element (the
    element's kind is :attr:`ElementModel.kind`) it is the change of its
    dynamics as a whole, reported in the same ``tau_*`` fields (the names are
    kept for compatibility).

    Numbers are None when the data could not support a fit (then every
    verdict is ``inconclusive`` and ``reasons`` say why).  Intervals are
    ``(low, high)`` at the configured confidence level.  A verdict is None
    where the property does not apply: ``tau_verdict`` of an integrating
    element (it has no time constant), every verdict but
    ``unmodeled_verdict`` of an empty cell, ``unmodeled_verdict`` of a
    modeled element.

    Attributes
    ----------
    gain_mismatch_pct, gain_mismatch_pct_interval : float, Interval
        ``dK = (K - Khat)/Khat`` [%].
    tau_mismatch_pct, tau_mismatch_pct_interval : float, Interval
        ``dtau`` [%] of a ``foptd`` element; the dynamics change
        ``100 (alpha - 1)`` [%] of a ``tf`` or ``step_response`` element
        with dynamics to scale; None otherwise (integrating ``K/s``, empty cells).
    delay_mismatch_samples : int
        ``dD = D - Dhat`` [samples].
    delay_confidence : float
        Profile-likelihood confidence of ``dD`` (of the interaction's delay in
        an empty cell) against its neighbours, 0..1.
    gain_verdict, tau_verdict, delay_verdict : str or None
        One of :data:`VERDICTS` per property, None where it does not apply.
    unmodeled_gain, unmodeled_gain_interval : float, Interval
        Empty cell only: the steady-state gain of the plant's interaction there
        [output unit / input unit; per time unit in an integrating row].
    unmodeled_delay_samples : int
        Empty cell only: the interaction's dead time [samples].
    unmodeled_verdict : str or None
        Empty cell only: ``mismatch`` (an interaction the model lacks), ``ok``
        (none of practical size) or ``inconclusive``.
    reasons : tuple of str
        Why a property is inconclusive.
    warnings : tuple of str
        Quality remarks that do not change a verdict.
    quality : Mapping
        Data-quality figures (coherence, excitation, condition, ...).
    instrument_shares : Mapping
        Which external signals carried the element's information: each
        instrument's share of the instrument-driven power of the element's
        regressor over the fitted band (``setpoint_<output>``,
        ``dither_<input>``, ``manual_<input>``, ``dv_<disturbance>``), summing
        to 1; empty where the row has no regression.
    more_data_factor : float or None
        For an inconclusive gain or time constant: how many times today's data
        at today's excitation would decide it, assuming the interval shrinks as
        ``1/sqrt(N)`` (``inf``: no amount at today's estimate); None otherwise.
    """

    gain_mismatch_pct: float | None = None
    gain_mismatch_pct_interval: Interval | None = None
    tau_mismatch_pct: float | None = None
    tau_mismatch_pct_interval: Interval | None = None
    delay_mismatch_samples: int | None = None
    delay_confidence: float | None = None
    gain_verdict: str | None = "inconclusive"
    tau_verdict: str | None = "inconclusive"
    delay_verdict: str | None = "inconclusive"
    unmodeled_gain: float | None = None
    unmodeled_gain_interval: Interval | None = None
    unmodeled_delay_samples: int | None = None
    unmodeled_verdict: str | None = None
    reasons: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()
    quality: Mapping[str, float] = field(default_factory=dict)
    instrument_shares: Mapping[str, float] = field(default_factory=dict)
    more_data_factor: float | None = None

    NUMBERS: ClassVar[tuple[str, ...]] = (
        "gain_mismatch_pct",
        "gain_mismatch_pct_interval",
        "tau_mismatch_pct",
        "tau_mismatch_pct_interval",
        "delay_mismatch_samples",
        "delay_confidence",
        "unmodeled_gain",
        "unmodeled_gain_interval",
        "unmodeled_delay_samples",
    )
    """The numeric fields (intervals are pairs), for plotting topics and tables."""

    @property
    def verdicts(self) -> tuple[str | None, str | None, str | None, str | None]:
        """The gain, time-constant, delay and interaction verdicts (None: does not apply)."""
        return self.gain_verdict, self.tau_verdict, self.delay_verdict, self.unmodeled_verdict

    @property
    def mismatches(self) -> tuple[str, ...]:
        """The properties (of :data:`PROPERTIES`) found mismatched."""
        return tuple(p for p, v in zip(PROPERTIES, self.verdicts, strict=True) if v == "mismatch")

    @property
    def verdict(self) -> str:
        """``mismatch`` if any property is, else ``inconclusive`` if any is, else ``ok``."""
        if "mismatch" in self.verdicts:
            return "mismatch"
        return "inconclusive" if "inconclusive" in self.verdicts else "ok"

    def summary(self) -> str:
        """One line: ``gain +15.0 % [+12.0, +18.0] MISMATCH, τ ... ok, delay +2 samples (99 %) MISMATCH``."""
        if self.unmodeled_gain is not None and self.unmodeled_gain_interval is not None:
            return self._interaction_summary()
        if self.gain_mismatch_pct is None or self.gain_mismatch_pct_interval is None:
            return "inconclusive: " + "; ".join(self.reasons)
        lo, hi = self.gain_mismatch_pct_interval
        parts = [f"gain {self.gain_mismatch_pct:+.1f} % [{lo:+.1f}, {hi:+.1f}] {_MARKS[self.gain_verdict]}"]
        if self.tau_mismatch_pct is not None and self.tau_mismatch_pct_interval is not None:
            lo, hi = self.tau_mismatch_pct_interval
            parts.append(f"τ {self.tau_mismatch_pct:+.1f} % [{lo:+.1f}, {hi:+.1f}] {_MARKS[self.tau_verdict]}")
        if self.delay_mismatch_samples is not None and self.delay_confidence is not None:
            confidence = 100 * self.delay_confidence
            parts.append(
                f"delay {self.delay_mismatch_samples:+d} samples ({confidence:.0f} %) {_MARKS[self.delay_verdict]}"
            )
        return ", ".join(parts)

    def _interaction_summary(self) -> str:
        assert self.unmodeled_gain is not None and self.unmodeled_gain_interval is not None
        lo, hi = self.unmodeled_gain_interval
        head = "unmodeled interaction" if self.unmodeled_verdict == "mismatch" else "no model"
        found = self.unmodeled_delay_samples is not None and self.unmodeled_verdict == "mismatch"
        delay = f", delay {self.unmodeled_delay_samples} samples" if found else ""
        return f"{head}: gain {self.unmodeled_gain:+.3g} [{lo:+.3g}, {hi:+.3g}]{delay} {_MARKS[self.unmodeled_verdict]}"


_MARKS = {"ok": "ok", "mismatch": "MISMATCH", "inconclusive": "?", None: "-"}
"""How :meth:`ParametricResult.summary` marks a verdict."""


@dataclass(frozen=True)
class ImpactResult:
    """What a mismatch does to control: the configured MPC on the plant as estimated vs as modelled.

    Attributes
    ----------
    ise_ratio : float
        Integrated squared tracking error (weighted by the MPC's output
        weights) on the plant as estimated over that on the plant as modelled;
        ``inf`` when the loop goes unstable.
    input_movement_ratio : float
        Sum of squared input moves (weighted by the move weights), the same ratio.
    rank : int
        1 for the element whose mismatch alone raises the tracking error most
        (among the elements with a mismatch); 0 for "all together".
    """

    ise_ratio: float
    input_movement_ratio: float
    rank: int = 0


@dataclass(frozen=True)
class DataQuality:
    """How far the data can be trusted for one element, whatever the method (never changes a verdict).

    Attributes
    ----------
    saturated_share : float or None
        Share of the diagnosed samples where the element's input sits at one of
        its limits (``mpc.u_min``, ``mpc.u_max``): samples that carry no
        excitation of it from the controller [-]; None when the limits are not
        known (plant data whose params file gives none).
    outside_share : float or None
        Share where it lies beyond them (the limits do not describe the data) [-].
    low_frequency_ratio : float or None
        The element's row: its residual spectrum at the lowest bins over its
        median (about 1 for white noise; large under a slow unmeasured
        disturbance, where the classic M(0) is read) [-]; None when the row has
        no regression.
    warnings : tuple of str
        The figures above their thresholds (``quality.*``), in words.
    """

    saturated_share: float | None
    outside_share: float | None
    low_frequency_ratio: float | None
    warnings: tuple[str, ...] = ()
