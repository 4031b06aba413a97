"""Parametric PMR: Delta K %, Delta tau %, Delta D per element, with confidence.

``ratio`` is the FOPTD-ratio model and its weighted least squares, ``fit`` the
row fit (delay search, two-pass noise, profile, covariance), ``guard`` the
data-quality checks, ``verdicts`` the calibrated verdicts, ``method`` the
whole diagnosis.
"""

from .method import diagnose_parametric, parametric_results
from .settings import ParametricSettings

__all__ = ["ParametricSettings", "diagnose_parametric", "parametric_results"]
