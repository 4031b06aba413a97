"""One entry point for both diagnosis methods."""

from __future__ import annotations

import numpy as np

from .foptd import FoptdMatrix
from .parametric import ParametricSettings, diagnose_parametric
from .pmr import METHODS, Diagnosis, PmrSettings, diagnose


def diagnose_with(
    r: np.ndarray,
    u: np.ndarray,
    y: np.ndarray,
    model: FoptdMatrix,
    settings: PmrSettings,
    parametric: ParametricSettings | None = None,
    method: str | None = None,
) -> Diagnosis:
    """Diagnose a record with ``method`` (default ``settings.method``).

    ``classic`` is :func:`pmr_ros.core.pmr.diagnose`.  ``parametric`` runs it
    too (its delays seed the fit and its tau index is kept for reference), then
    replaces each element's gain ratio, delay, flags and verdict by those of
    :func:`pmr_ros.core.parametric.diagnose_parametric`; the classic numbers
    stay in ``ElementDiagnosis.classic``.

    Parameters
    ----------
    r, u, y : ndarray
        Setpoints, inputs and measured outputs, one row per sample.
    model : FoptdMatrix
        The controller's model ``Ghat``.
    settings : PmrSettings
    parametric : ParametricSettings, optional
        Default: its defaults.
    method : str, optional
        ``classic`` or ``parametric``.
    """
    method = method or settings.method
    if method not in METHODS:
        raise ValueError(f"unknown diagnosis method {method!r}; choose one of {', '.join(METHODS)}")
    diagnosis = diagnose(r, u, y, model, settings)
    diagnosis.method = method
    if method == "classic" or diagnosis.status != "ok":
        return diagnosis
    parametric = parametric or ParametricSettings()
    _, _, estimates = diagnose_parametric(r, u, y, model, settings, parametric)
    for name, element in diagnosis.elements.items():
        p = estimates[name]
        element.classic = {"gain_ratio": element.gain_ratio, "tau_index": element.tau_index, "delay_mismatch_samples": element.delay_mismatch_samples}
        element.parametric = p
        element.gain_ratio = None if p.gain_mismatch_pct is None else 1.0 + p.gain_mismatch_pct / 100.0
        element.gain_mismatch = p.gain_verdict == "mismatch"
        element.tau_mismatch = p.tau_verdict == "mismatch"
        element.delay_mismatch_samples = p.delay_mismatch_samples
        element.delay_mismatch = p.delay_verdict == "mismatch"
        element.reasons = list(p.reasons)
    return diagnosis
