"""The classic PMR diagnosis of the paper's Table 1, and the spectral settings both methods share.

Per element: the gain ratio from ``G_PMR(0)``, the time-constant index
``-100 x`` the slope of ``M(w)/M(0)`` on ``(0, tau_band]``, and the delay
mismatch from the Hilbert/Hamon-Hannan search (:mod:`pmr_ros.core.delay`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .delay import hamon_hannan_delay, informative_band
from .foptd import FoptdMatrix
from .implicit import PmrEstimate, estimate_pmr
from .record import InsufficientData
from .results import ClassicResult, Diagnosis, ElementDiagnosis
from .spectra import WelchSettings

__all__ = ["MAX_CONDITION", "PmrSettings", "classic_estimate", "classic_results", "diagnose_classic"]

MAX_CONDITION = 1e6
"""Largest condition number of a row regression the classic method accepts in its band."""


@dataclass(frozen=True)
class PmrSettings:
    """Spectral estimate and classic-diagnosis thresholds (the ``pmr`` block).

    Defaults and ranges: ``config/parameters.yaml``.

    Attributes
    ----------
    method : str
        ``classic`` or ``parametric``: which method gives the verdicts.
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
        Delay mismatches searched over ``-max .. +max`` samples (both methods).
    coherence_min : float
        The delay search uses the band from 0 up to where the row's squared
        coherence with the setpoints first falls below this.
    """

    method: str
    window: str
    segment_length: int
    overlap: float
    tau_band: float
    gain_tolerance: float
    tau_index_threshold: float
    max_delay_samples: int
    coherence_min: float

    @property
    def welch(self) -> WelchSettings:
        """The Welch estimator of the classic method."""
        return WelchSettings(self.window, self.segment_length, self.overlap)


def classic_results(estimate: PmrEstimate, model: FoptdMatrix, settings: PmrSettings) -> dict[str, ClassicResult]:
    """Table 1 per element from a PMR estimate: gain ratio, tau index, delay and their flags.

    Parameters
    ----------
    estimate : PmrEstimate
    model : FoptdMatrix
        The controller's model (element names).
    settings : PmrSettings
        Thresholds, tau band and delay search.

    Returns
    -------
    dict
        Element name to :class:`ClassicResult`, row-major.
    """
    omega = estimate.omega
    band = (omega > 0) & (omega <= settings.tau_band + 1e-12)
    names = model.element_names()
    out = {}
    for j, name in enumerate(names):
        i, k = divmod(j, model.n_inputs)
        response = estimate.ratio[:, i, k]
        gain_ratio = float(response[0].real)
        slope = np.polyfit(omega[band], np.abs(response[band]) / abs(gain_ratio), 1)[0]
        tau_index = float(-100.0 * slope)
        delay_band = informative_band(omega, estimate.coherence[:, i], settings.coherence_min)
        delay, _ = hamon_hannan_delay(omega, response, estimate.coherence[:, i], settings.max_delay_samples, delay_band)
        out[name] = ClassicResult(
            gain_ratio=gain_ratio,
            tau_index=tau_index,
            delay_mismatch_samples=delay,
            gain_mismatch=bool(abs(gain_ratio - 1.0) > settings.gain_tolerance),
            tau_mismatch=bool(abs(tau_index) > settings.tau_index_threshold),
            delay_mismatch=delay != 0,
        )
    return out


def classic_estimate(
    r: np.ndarray, u: np.ndarray, y: np.ndarray, *, model: FoptdMatrix, settings: PmrSettings
) -> PmrEstimate:
    """The PMR estimate of the classic method, refused when a row regression is ill-conditioned.

    Raises
    ------
    InsufficientData
        The record cannot support it (the message says why).
    """
    estimate = estimate_pmr(r, u, y, model=model, welch=settings.welch)
    band = (estimate.omega > 0) & (estimate.omega <= settings.tau_band + 1e-12)
    worst = estimate.condition[band | (estimate.omega == 0)].max()
    if not np.isfinite(worst) or worst > MAX_CONDITION:
        raise InsufficientData(
            f"ill-conditioned regression (condition number {worst:.3g} > {MAX_CONDITION:g}): "
            "the setpoints do not excite the inputs independently"
        )
    return estimate


def diagnose_classic(
    r: np.ndarray, u: np.ndarray, y: np.ndarray, *, model: FoptdMatrix, settings: PmrSettings
) -> Diagnosis:
    """Classic (Table 1) diagnosis of every element from closed-loop records.

    Parameters
    ----------
    r, u, y : ndarray
        Setpoints, inputs and measured outputs, one row per sample.
    model : FoptdMatrix
        The controller's model ``Ghat``.
    settings : PmrSettings

    Returns
    -------
    Diagnosis
        ``status`` ``insufficient_data`` (with the reason, no numbers) when the
        record cannot support one.
    """
    samples = int(np.shape(r)[0]) if np.ndim(r) else 0
    models = model.element_models()
    try:
        estimate = classic_estimate(r, u, y, model=model, settings=settings)
    except InsufficientData as exc:
        return Diagnosis.insufficient(method="classic", models=models, reason=str(exc), samples=samples)
    results = classic_results(estimate, model, settings)
    elements = {
        name: ElementDiagnosis(name, i, k, element, "classic", classic=results[name])
        for name, (i, k, element) in models.items()
    }
    return Diagnosis("classic", "ok", "", samples, elements, estimate)
