"""The improved MIMO plant-model ratio (PMR): estimate and classic diagnosis.

For output row i the implicit estimate (paper's eq. 13) solves, at every
frequency, the setpoint-correlated regression

    S_{r_l y_i}(w) = sum_k S_{r_l yhat_ik}(w) G_PMR_ik(w),   l = 1 .. n_setpoints

with ``yhat_ik = Ghat_ik u_k`` the model's share of output i due to input k.
Noise and disturbances drop out because they are uncorrelated with r.

The classic diagnosis (Table 1) per element reads the gain ratio from
``G_PMR(0)``, the time-constant index ``-100 x`` the slope of ``M(w)/M(0)`` on
``(0, tau_band]``, and the delay mismatch from the Hilbert/Hamon-Hannan search.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .delay import hamon_hannan_delay, informative_band
from .foptd import FoptdMatrix
from .spectra import WelchSettings, segment_spectra

if TYPE_CHECKING:
    from .parametric import ElementEstimate

MIN_SEGMENTS = 4
"""Fewest Welch segments with which a row regression is attempted."""

METHODS = ("classic", "parametric")
"""Diagnosis methods: the paper's Table 1, or the FOPTD-ratio fit of :mod:`pmr_ros.core.parametric`."""

MAX_CONDITION = 1e6
"""Largest condition number of a row regression accepted in the diagnosis band."""


@dataclass(frozen=True)
class PmrSettings:
    """Spectral estimate and classic-diagnosis thresholds.

    Attributes
    ----------
    method : str
        ``classic`` or ``parametric`` (see :data:`METHODS`).
    window, segment_length, overlap
        Welch estimator (see :class:`~pmr_ros.core.spectra.WelchSettings`).
    tau_band : float
        Upper end of the band of the time-constant slope fit [rad/sample]
        (0.4, after Yerramilli & Tangirala 2018).
    gain_tolerance : float
        ``|M(0) - 1|`` above this is a gain mismatch.
    tau_index_threshold : float
        ``|tau index|`` above this is a time-constant mismatch.
    max_delay_samples : int
        Delay mismatches searched over ``-max .. +max`` samples.
    coherence_min : float
        The delay search uses the band from 0 up to where the row's squared
        coherence with the setpoints first falls below this.
    """

    method: str = "classic"
    window: str = "hann"
    segment_length: int = 512
    overlap: float = 0.5
    tau_band: float = 0.4
    gain_tolerance: float = 0.05
    tau_index_threshold: float = 5.0
    max_delay_samples: int = 10
    coherence_min: float = 0.5

    @property
    def welch(self) -> WelchSettings:
        return WelchSettings(self.window, self.segment_length, self.overlap)


@dataclass(frozen=True)
class PmrEstimate:
    """The estimated PMR matrix over frequency.

    Attributes
    ----------
    omega : ndarray, shape (F,)
        Frequencies 0 .. pi [rad/sample].
    ratio : ndarray of complex, shape (F, n_outputs, n_inputs)
        ``G_PMR_ik(w)``.
    coherence : ndarray, shape (F, n_outputs)
        Multiple squared coherence of output i with the setpoints: the share
        of its spectrum the setpoints explain.
    condition : ndarray, shape (F, n_outputs)
        Condition number of each row's regression matrix.
    segments : int
        Welch segments averaged.
    """

    omega: np.ndarray
    ratio: np.ndarray
    coherence: np.ndarray
    condition: np.ndarray
    segments: int


@dataclass
class ElementDiagnosis:
    """Diagnosis of one element ``G_ik``.

    The classic (Table 1) numbers are always there when the data allowed:
    ``gain_ratio`` is ``K / Khat``; ``tau_index`` is -100 x the slope of
    ``M(w)/M(0)`` [1/(rad/sample)], positive when the plant is slower than the
    model; ``delay_mismatch_samples`` is ``D - Dhat``.  With the parametric
    method, ``parametric`` holds its estimate, and the gain ratio, delay,
    mismatch flags, reasons, verdict and message are the parametric ones
    (``tau_index`` stays the classic index, ``classic`` keeps the classic numbers).
    All numbers are None when the data were insufficient.
    """

    element: str
    gain_ratio: float | None = None
    gain_mismatch: bool | None = None
    tau_index: float | None = None
    tau_mismatch: bool | None = None
    delay_mismatch_samples: int | None = None
    delay_mismatch: bool | None = None
    reasons: list[str] = field(default_factory=list)
    parametric: ElementEstimate | None = None
    classic: dict | None = None

    @property
    def gain_direction(self) -> str:
        if not self.gain_mismatch:
            return "ok"
        return "higher" if self.gain_ratio > 1 else "lower"

    @property
    def tau_direction(self) -> str:
        if not self.tau_mismatch:
            return "ok"
        value = self.parametric.tau_mismatch_pct if self.parametric is not None else self.tau_index
        return "larger" if value > 0 else "smaller"

    @property
    def verdict(self) -> str:
        """``ok``, ``mismatch`` or ``inconclusive`` (the data cannot say; see ``reasons``)."""
        if self.parametric is not None:
            return self.parametric.verdict
        if self.gain_ratio is None:
            return "inconclusive"
        return "mismatch" if (self.gain_mismatch or self.tau_mismatch or self.delay_mismatch) else "ok"

    def summary(self) -> str:
        """One line for people: ``gain +15 %, tau larger, delay +2 samples``."""
        if self.parametric is not None:
            return self.parametric.summary()
        if self.gain_ratio is None:
            return "insufficient data" + (f": {self.reasons[0]}" if self.reasons else "")
        gain = f"gain {100 * (self.gain_ratio - 1):+.0f} %" if self.gain_mismatch else "gain ok"
        tau = f"τ {self.tau_direction} (index {self.tau_index:+.0f})" if self.tau_mismatch else "τ ok"
        delay = f"delay {self.delay_mismatch_samples:+d} samples" if self.delay_mismatch else "delay ok"
        return f"{gain}, {tau}, {delay}"

    def to_dict(self) -> dict:
        """JSON-ready numbers, verdicts, intervals and quality figures."""
        out = {
            "gain_ratio": self.gain_ratio,
            "gain_mismatch": self.gain_mismatch,
            "tau_index": self.tau_index,
            "tau_mismatch": self.tau_mismatch,
            "delay_mismatch_samples": self.delay_mismatch_samples,
            "delay_mismatch": self.delay_mismatch,
            "gain_direction": self.gain_direction,
            "tau_direction": self.tau_direction,
            "verdict": self.verdict,
            "gain_mismatch_pct": None if self.gain_ratio is None else 100.0 * (self.gain_ratio - 1.0),
            "gain_mismatch_pct_interval": None,
            "tau_mismatch_pct": None,
            "tau_mismatch_pct_interval": None,
            "delay_confidence": None,
            "reasons": list(self.reasons),
        }
        p = self.parametric
        if p is not None:
            out.update(
                gain_mismatch_pct=p.gain_mismatch_pct,
                gain_mismatch_pct_interval=None if p.gain_mismatch_pct_interval is None else list(p.gain_mismatch_pct_interval),
                tau_mismatch_pct=p.tau_mismatch_pct,
                tau_mismatch_pct_interval=None if p.tau_mismatch_pct_interval is None else list(p.tau_mismatch_pct_interval),
                delay_confidence=p.delay_confidence,
                gain_verdict=p.gain_verdict,
                tau_verdict=p.tau_verdict,
                delay_verdict=p.delay_verdict,
                warnings=list(p.warnings),
                quality=dict(p.quality),
                classic=self.classic,
            )
        return out


@dataclass
class Diagnosis:
    """The diagnosis of every element, or why there is none."""

    elements: dict[str, ElementDiagnosis]
    status: str = "ok"  # "ok" or "insufficient_data"
    reason: str = ""
    samples: int = 0
    estimate: PmrEstimate | None = field(default=None, repr=False)
    method: str = "classic"

    def to_dict(self) -> dict:
        return {
            "status": self.status,
            "reason": self.reason,
            "samples": self.samples,
            "method": self.method,
            "elements": {name: e.to_dict() for name, e in self.elements.items()},
        }


class InsufficientData(ValueError):
    """The record cannot support a PMR estimate; the message says why."""


def check_record(r: np.ndarray, u: np.ndarray, y: np.ndarray, model: FoptdMatrix, settings: PmrSettings) -> None:
    """Raise :class:`InsufficientData` if the record cannot support an estimate."""
    n_out, n_in = model.n_outputs, model.n_inputs
    for name, data, width in (("r", r, n_out), ("u", u, n_in), ("y", y, n_out)):
        if data.ndim != 2 or data.shape[1] != width:
            raise InsufficientData(f"{name} has shape {data.shape}, expected (samples, {width})")
        if not np.all(np.isfinite(data)):
            raise InsufficientData(f"{name} holds NaN or inf samples")
    samples = r.shape[0]
    if u.shape[0] != samples or y.shape[0] != samples:
        raise InsufficientData("r, u and y have different lengths")
    warmup = model.settling_samples()
    segments = settings.welch.segments(samples - warmup)
    need = max(MIN_SEGMENTS, 2 * n_out)
    if segments < need:
        shortest = warmup + settings.segment_length + (need - 1) * (settings.segment_length - int(settings.segment_length * settings.overlap))
        raise InsufficientData(
            f"window too short: {samples} samples less {warmup} of model settling give {segments} Welch segments, need {need} ({shortest} samples)"
        )
    spread = r.std(axis=0)
    for j, s in enumerate(spread):
        if s <= 1e-9 * (1.0 + abs(r[:, j].mean())):
            raise InsufficientData(f"no excitation: setpoint r{j + 1} ({model.output_names[j]}) is constant")


@dataclass(frozen=True)
class RecordSpectra:
    """The cross-spectra of a record that the PMR needs, from one Welch transform.

    Attributes
    ----------
    omega : ndarray, shape (F,)
        Frequencies 0 .. pi [rad/sample].
    rr : ndarray, shape (F, n_r, n_r)
        Setpoint spectra ``S_{r r}``.
    ry : ndarray, shape (F, n_r, n_out)
        ``S_{r_l y_i}``.
    ryhat : ndarray, shape (F, n_r, n_out, n_in)
        ``S_{r_l yhat_ik}``.
    yy : ndarray, shape (F, n_out)
        Output auto-spectra ``S_{y_i y_i}`` (real).
    yhat_y : ndarray, shape (F, n_out, n_in)
        ``S_{yhat_ik y_i}``.
    yhat_yhat : ndarray, shape (F, n_out, n_in, n_in)
        ``S_{yhat_ik yhat_im}``.
    segments : int
        Welch segments averaged.
    equivalent_segments : float
        Independent segments they are worth (overlap).
    settings : WelchSettings
    """

    omega: np.ndarray
    rr: np.ndarray
    ry: np.ndarray
    ryhat: np.ndarray
    yy: np.ndarray
    yhat_y: np.ndarray
    yhat_yhat: np.ndarray
    segments: int
    equivalent_segments: float
    settings: WelchSettings


def record_spectra(r: np.ndarray, u: np.ndarray, y: np.ndarray, model: FoptdMatrix, welch: WelchSettings) -> RecordSpectra:
    """Spectra of setpoints, outputs and per-element model outputs ``yhat_ik = Ghat_ik u_k``.

    The model's settling time (:meth:`FoptdMatrix.settling_samples`) is dropped
    from the start of every signal: ``yhat``'s filters start from a guessed state.
    The record must have passed :func:`check_record`.
    """
    n_out, n_in = model.n_outputs, model.n_inputs
    n_r = r.shape[1]
    yhat = model.element_outputs(u).reshape(u.shape[0], n_out * n_in)
    warmup = model.settling_samples()
    seg = segment_spectra(np.hstack([r, y, yhat])[warmup:], welch)
    R = slice(0, n_r)
    Y = slice(n_r, n_r + n_out)
    F = seg.omega.size
    yhat_cols = np.arange(n_r + n_out, n_r + n_out + n_out * n_in).reshape(n_out, n_in)
    yy = np.stack([seg.cross([n_r + i], [n_r + i])[:, 0, 0].real for i in range(n_out)], axis=1)
    yhat_y = np.stack([seg.cross(yhat_cols[i], [n_r + i])[:, :, 0] for i in range(n_out)], axis=1)
    yhat_yhat = np.stack([seg.cross(yhat_cols[i], yhat_cols[i]) for i in range(n_out)], axis=1)
    return RecordSpectra(
        omega=seg.omega,
        rr=seg.cross(R, R),
        ry=seg.cross(R, Y),
        ryhat=seg.cross(R, yhat_cols.ravel()).reshape(F, n_r, n_out, n_in),
        yy=yy,
        yhat_y=yhat_y,
        yhat_yhat=yhat_yhat,
        segments=seg.segments,
        equivalent_segments=welch.equivalent_segments(seg.segments),
        settings=welch,
    )


def estimate_pmr(r: np.ndarray, u: np.ndarray, y: np.ndarray, model: FoptdMatrix, settings: PmrSettings) -> PmrEstimate:
    """The implicit MIMO PMR estimate (eq. 13) from closed-loop records.

    Parameters
    ----------
    r : ndarray, shape (N, n_outputs)
        Setpoints [output unit].
    u : ndarray, shape (N, n_inputs)
        Manipulated inputs [input unit].
    y : ndarray, shape (N, n_outputs)
        Measured outputs [output unit].
    model : FoptdMatrix
        The controller's model ``Ghat``.
    settings : PmrSettings

    Raises
    ------
    InsufficientData
    """
    r, u, y = (np.asarray(a, dtype=float) for a in (r, u, y))
    check_record(r, u, y, model, settings)
    spectra = record_spectra(r, u, y, model, settings.welch)
    return implicit_estimate(spectra)


def implicit_estimate(spectra: RecordSpectra) -> PmrEstimate:
    """Solve eq. (13) row by row and frequency by frequency."""
    F, _, n_out, n_in = spectra.ryhat.shape
    ratio = np.empty((F, n_out, n_in), dtype=complex)
    condition = np.empty((F, n_out))
    coherence = np.empty((F, n_out))
    rr_inv = np.linalg.pinv(spectra.rr)
    for i in range(n_out):
        design = spectra.ryhat[:, :, i, :]  # (F, n_r, n_in)
        target = spectra.ry[:, :, i]  # (F, n_r)
        ratio[:, i, :] = (np.linalg.pinv(design) @ target[:, :, None])[:, :, 0]
        condition[:, i] = np.linalg.cond(design)
        explained = np.einsum("fl,flm,fm->f", target.conj(), rr_inv, target).real
        coherence[:, i] = np.clip(explained / np.maximum(spectra.yy[:, i], 1e-300), 0.0, 1.0)
    return PmrEstimate(spectra.omega, ratio, coherence, condition, spectra.segments)


def diagnose(r: np.ndarray, u: np.ndarray, y: np.ndarray, model: FoptdMatrix, settings: PmrSettings) -> Diagnosis:
    """Classic (Table 1) diagnosis of every element from closed-loop records.

    Returns a :class:`Diagnosis` whose ``status`` is ``insufficient_data``
    (with the reason, and no numbers) when the record cannot support one.
    Arguments as for :func:`estimate_pmr`.
    """
    names = model.element_names()
    samples = int(np.shape(r)[0]) if np.ndim(r) else 0
    try:
        estimate = estimate_pmr(r, u, y, model, settings)
        band = (estimate.omega > 0) & (estimate.omega <= settings.tau_band + 1e-12)
        worst = estimate.condition[band | (estimate.omega == 0)].max()
        if not np.isfinite(worst) or worst > MAX_CONDITION:
            raise InsufficientData(f"ill-conditioned regression (condition number {worst:.3g} > {MAX_CONDITION:g}): the setpoints do not excite the inputs independently")
    except InsufficientData as exc:
        return Diagnosis({n: ElementDiagnosis(n, reasons=[str(exc)]) for n in names}, "insufficient_data", str(exc), samples)

    omega = estimate.omega
    elements: dict[str, ElementDiagnosis] = {}
    for i in range(model.n_outputs):
        for k in range(model.n_inputs):
            name = names[i * model.n_inputs + k]
            response = estimate.ratio[:, i, k]
            gain_ratio = float(response[0].real)
            magnitude = np.abs(response)
            slope = np.polyfit(omega[band], magnitude[band] / abs(gain_ratio), 1)[0]
            tau_index = float(-100.0 * slope)
            delay_band = informative_band(omega, estimate.coherence[:, i], settings.coherence_min)
            delay, _ = hamon_hannan_delay(omega, response, estimate.coherence[:, i], settings.max_delay_samples, delay_band)
            elements[name] = ElementDiagnosis(
                element=name,
                gain_ratio=gain_ratio,
                gain_mismatch=bool(abs(gain_ratio - 1.0) > settings.gain_tolerance),
                tau_index=tau_index,
                tau_mismatch=bool(abs(tau_index) > settings.tau_index_threshold),
                delay_mismatch_samples=delay,
                delay_mismatch=delay != 0,
            )
    return Diagnosis(elements, "ok", "", samples, estimate)
