"""What the report's figures plot per element: the spectral PMR with its confidence band, the fitted curve.

The estimate is the implicit MIMO PMR (eq. 13 of the paper,
:func:`pmr_ros.core.pmr.implicit.implicit_estimate`) from the same stretches and
Welch segments the diagnosis used; the fitted curve is the parametric
result's ratio: the FOPTD one (:func:`pmr_ros.core.pmr.parametric.ratio.ratio_shape`),
or the best scaled model ``rho Ghat(s alpha) e^{-dD s}`` over ``Ghat`` of an
element of any type (:mod:`pmr_ros.core.pmr.parametric.scaled`).  With the
model element's own frequency response (:attr:`ElementCurves.model_response`)
both are the plant's: the estimated frequency response against the best
scaled model, which shows a plant that differs in shape.

Confidence band.  Per output row i and frequency w the estimate solves
``b = A theta`` with ``b = S_{z y_i}`` and ``A = S_{z yhat_i}`` (z the
instruments), ``theta_hat = A^+ b``.  At the true ratio the equation error
``e = b - A theta = S_{z v_i}`` (v_i the part of y_i the instruments do not
explain) has covariance ``S_zz Phi_v / M`` (M the equivalent number of
independent Welch segments, Welch 1967), so

    cov(theta_hat) = A^+ S_zz A^+^H Phi_v / M,

with ``Phi_v`` the row's residual spectrum (of ``y_i - sum_k theta_k yhat_ik``:
what drives the inputs besides the instruments, e.g. noise fed back in a closed
loop, cancels in it).  For one input driven by one instrument alone this is
``|theta|^2 (1 - gamma^2) / (gamma^2 M)``, gamma^2 the coherence: the random
error of a frequency-response estimate in Bendat & Piersol, *Random Data*,
4th ed. (Wiley 2010), ch. 9 (normalized error ``sqrt(1 - gamma^2) / (|gamma|
sqrt(2 n_d))`` of the magnitude, half the complex variance).  The estimate's error is circular complex normal, so
``|theta_hat - theta|^2 / sigma^2`` is exponential and the band of level p
is the disc of radius ``sigma sqrt(-ln(1 - p))``: on the magnitude
``|theta_hat| +- radius``, on the phase ``+- arcsin(radius / |theta_hat|)``.
The band holds at each frequency on its own, not over all at once; on the
Wood-Berry closed loop it covers 0.92 of the informative bins at 95 %
(slightly fewer near the band's end, where the coherence falls).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..records import Record
from ..results import Diagnosis, ElementDiagnosis
from ..sim.lti import Element
from ..sim.model import TransferMatrix
from .checks import InsufficientData, check_stretches
from .classic import PmrSettings
from .delay import informative_band
from .implicit import PmrEstimate, implicit_estimate, instrument_factor
from .parametric.ratio import noise_spectrum, ratio_shape, row_system
from .parametric.scaled import ScaledShape
from .parametric.settings import ParametricSettings
from .spectra import RecordSpectra, WelchSettings, record_spectra

__all__ = ["CurveSettings", "ElementCurves", "band_radius", "estimate_sigma", "fitted_ratio", "pmr_curves", "welch_of"]


class CurveSettings(Protocol):
    """What the curves read of a configuration (:class:`pmr_ros.config.PmrConfig` is one)."""

    @property
    def model(self) -> TransferMatrix:
        """The controller's model."""
        ...

    @property
    def pmr(self) -> PmrSettings:
        """The spectral settings (Welch segments, coherence threshold)."""
        ...

    @property
    def parametric(self) -> ParametricSettings:
        """The parametric method's settings (its Welch segments, the confidence level)."""
        ...


@dataclass(frozen=True)
class ElementCurves:
    """One element's curves over frequency.

    Attributes
    ----------
    name : str
        ``G21``.
    omega : ndarray, shape (F,)
        Frequencies 0 .. pi [rad/sample].
    estimate : ndarray of complex, shape (F,)
        The spectral PMR estimate.
    sigma : ndarray, shape (F,)
        Standard deviation of the complex estimate (``E|error|^2 = sigma^2``).
    coherence : ndarray, shape (F,)
        Squared coherence of the element's output row with the instruments.
    band : ndarray of bool, shape (F,)
        The row's informative band (0 and where the coherence holds).
    fitted : ndarray of complex or None
        The parametric result's fitted ratio (None without one).
    level : float
        Confidence level of the band.
    model_response : ndarray of complex or None
        The model element's frequency response ``Ghat(e^jw)`` (None: not kept);
        times :attr:`estimate` the plant's estimated frequency response, times
        :attr:`fitted` the best scaled model's.
    """

    name: str
    omega: np.ndarray
    estimate: np.ndarray
    sigma: np.ndarray
    coherence: np.ndarray
    band: np.ndarray
    fitted: np.ndarray | None
    level: float
    model_response: np.ndarray | None = None

    @property
    def radius(self) -> np.ndarray:
        """Radius of the confidence disc around the estimate at each frequency."""
        return band_radius(self.sigma, self.level)

    @property
    def plant_estimate(self) -> np.ndarray | None:
        """The plant's estimated frequency response ``estimate * Ghat``; None without :attr:`model_response`."""
        return None if self.model_response is None else self.estimate * self.model_response

    @property
    def plant_fitted(self) -> np.ndarray | None:
        """The best scaled model's frequency response ``fitted * Ghat``; None without either."""
        if self.model_response is None or self.fitted is None:
            return None
        return self.fitted * self.model_response


def band_radius(sigma: np.ndarray, level: float) -> np.ndarray:
    """Radius of the ``level`` confidence disc of a circular complex normal error of standard deviation ``sigma``.

    Examples
    --------
    >>> float(band_radius(np.array([1.0]), 0.95)[0])  # sqrt(ln 20)
    1.7308183826022854
    """
    return np.asarray(sigma) * np.sqrt(-np.log1p(-level))


def estimate_sigma(spectra: RecordSpectra, estimate: PmrEstimate, row: int) -> np.ndarray:
    """Standard deviation of the implicit estimate of every element of ``row``, shape (F, n_inputs).

    The per-bin least-squares estimate's variance from the row's whitened
    equations (:func:`~pmr_ros.core.pmr.parametric.ratio.row_system`, the noise
    spectrum of the estimate's own residual): ``E|error|^2 = 2 [M^-1]_kk``.
    NaN where the row's layout has no column.
    """
    F, n_in = spectra.omega.size, estimate.ratio.shape[2]
    sigma = np.full((F, n_in), np.nan)
    columns = estimate.layouts[row].columns
    if columns.size == 0:
        return sigma
    row_spectra = spectra.row(row)
    noise = noise_spectrum(row_spectra, columns, estimate.ratio[:, row, columns], spectra.omega)
    system = row_system(
        row_spectra,
        instrument_factor(spectra.rr),
        columns=columns,
        noise=noise,
        bins=np.arange(F),
        omega=spectra.omega,
        equivalent_segments=spectra.equivalent_segments,
    )
    _, variance = system.free_estimate()
    sigma[:, columns] = np.sqrt(2.0 * variance)
    return sigma


def fitted_ratio(
    element: ElementDiagnosis, omega: np.ndarray, sample_time: float, *, model_element: Element | None = None
) -> np.ndarray | None:
    """The parametric result's PMR ``rho (1-a)/(1-ahat) (1-ahat z^-1)/(1-a z^-1) z^-dD`` at ``omega``.

    An integrating element's ratio is ``rho z^-dD``; a ``tf`` or
    ``step_response`` element's ``rho Ghat_alpha / Ghat z^-dD``
    (:class:`~.parametric.scaled.ScaledShape`, ``alpha - 1`` its reported
    dynamics change), which needs the element itself as ``model_element``.
    None without a fitted result.
    """
    result, model = element.parametric, element.model
    if result is None or result.gain_mismatch_pct is None or result.delay_mismatch_samples is None:
        return None
    omega = np.asarray(omega, dtype=float)
    z_inv = np.exp(-1j * omega)
    rho = 1.0 + result.gain_mismatch_pct / 100.0
    delay = int(result.delay_mismatch_samples)
    if model.kind in ("tf", "step_response") and model_element is not None and result.tau_mismatch_pct is not None:
        alpha = 1.0 + result.tau_mismatch_pct / 100.0
        return rho * ScaledShape(model_element).ratio(omega, alpha) * z_inv**delay
    if model.time_constant is None or result.tau_mismatch_pct is None:
        return rho * z_inv**delay
    tau_hat = model.time_constant
    tau = tau_hat * (1.0 + result.tau_mismatch_pct / 100.0)
    return rho * ratio_shape(z_inv, np.exp(-sample_time / tau_hat), np.exp(-sample_time / tau), delay)


def welch_of(diagnosis: Diagnosis, stretches: Sequence[Record], config: CurveSettings) -> WelchSettings:
    """The Welch segments the diagnosis's method used on these stretches."""
    if diagnosis.method == "parametric":
        return config.parametric.welch_for(config.model, stretches, config.pmr)
    return config.pmr.welch


def pmr_curves(stretches: Sequence[Record], diagnosis: Diagnosis, config: CurveSettings) -> dict[str, ElementCurves]:
    """The curves of every present element, from the stretches the diagnosis read; empty when it had no numbers.

    Parameters
    ----------
    stretches : sequence of Record
    diagnosis : Diagnosis
        Its method picks the Welch segments; its parametric results give the fitted curves.
    config : CurveSettings
        The model and the spectral settings.
    """
    if diagnosis.status != "ok" or not stretches:
        return {}
    model = config.model
    welch = welch_of(diagnosis, stretches, config)
    try:
        check_stretches(stretches, model=model, welch=welch)
    except InsufficientData:
        return {}
    spectra = record_spectra(stretches, model, welch)
    estimate = implicit_estimate(spectra, test_empty=False)
    level = config.parametric.confidence_level
    out = {}
    for i in range(model.n_outputs):
        sigma = estimate_sigma(spectra, estimate, i)
        band = informative_band(spectra.omega, estimate.coherence[:, i], config.pmr.coherence_min)
        band[0] = True
        for k in range(model.n_inputs):
            element = diagnosis.elements[model.element_names()[i * model.n_inputs + k]]
            if element.model.kind == "none":
                continue
            cell = model.element(i, k)
            out[element.name] = ElementCurves(
                element.name,
                spectra.omega,
                estimate.ratio[:, i, k],
                sigma[:, k],
                estimate.coherence[:, i],
                band,
                fitted_ratio(element, spectra.omega, model.sample_time, model_element=cell),
                level,
                cell.frequency_response(spectra.omega),
            )
    return out
