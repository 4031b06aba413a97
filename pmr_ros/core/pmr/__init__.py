"""The plant-model ratio diagnosis: data checks, spectra, the implicit PMR, the classic and parametric methods.

``checks`` whether the data can support an estimate, ``spectra`` Welch
cross-spectra, ``implicit`` the PMR frequency by frequency, ``classic`` the
paper's Table 1, ``parametric`` fitted dK %, dtau %, dD with verdicts,
``delay`` the delay from the PMR's phase, ``data_quality`` limits and slow
disturbances, ``diagnosis`` one entry point for every method, ``curves`` the
PMR curves the report plots.

The names below are imported when first used, so importing one module of
this package does not load the others.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..._lazy import lazy_exports

_WHERE = {
    "CurveSettings": "curves",
    "ElementCurves": "curves",
    "EstimateBuilder": "implicit",
    "InsufficientData": "checks",
    "MAX_CONDITION": "classic",
    "METHODS": "diagnosis",
    "MIN_SEGMENTS": "checks",
    "ParametricSettings": "parametric",
    "PmrEstimate": "implicit",
    "PmrSettings": "classic",
    "QualitySettings": "data_quality",
    "RecordQuality": "data_quality",
    "RecordSpectra": "spectra",
    "RowEstimate": "implicit",
    "RowLayout": "implicit",
    "RowSpectra": "spectra",
    "SegmentSpectra": "spectra",
    "WelchSettings": "spectra",
    "assess": "data_quality",
    "band_radius": "curves",
    "check_record": "checks",
    "check_stretches": "checks",
    "classic_estimate": "classic",
    "classic_results": "classic",
    "cross_spectra": "spectra",
    "diagnose": "diagnosis",
    "diagnose_classic": "classic",
    "diagnose_parametric": "parametric",
    "diagnose_stretches": "diagnosis",
    "element_warnings": "data_quality",
    "estimate_pmr": "implicit",
    "estimate_sigma": "curves",
    "fitted_ratio": "curves",
    "gain_bin": "classic",
    "hamon_hannan_delay": "delay",
    "hermitian_product": "products",
    "implicit_estimate": "implicit",
    "implicit_row": "implicit",
    "informative_band": "delay",
    "instrument_factor": "implicit",
    "low_frequency_ratio": "data_quality",
    "minimum_phase": "delay",
    "parametric_results": "parametric",
    "pmr_curves": "curves",
    "product": "products",
    "readable": "classic",
    "record_spectra": "spectra",
    "residual_spectra": "data_quality",
    "row_layout": "implicit",
    "row_refusal": "classic",
    "row_regressors": "regressors",
    "saturation": "data_quality",
    "search_limit_reason": "delay",
    "segment_spectra": "spectra",
    "shortest_useful_stretch": "diagnosis",
    "stretch_segments": "spectra",
    "useful_stretches": "diagnosis",
    "welch_of": "curves",
    "with_data_quality": "diagnosis",
}
"""Each public name -> the module of this package that defines it."""

__all__ = [
    "CurveSettings",
    "ElementCurves",
    "EstimateBuilder",
    "InsufficientData",
    "MAX_CONDITION",
    "METHODS",
    "MIN_SEGMENTS",
    "ParametricSettings",
    "PmrEstimate",
    "PmrSettings",
    "QualitySettings",
    "RecordQuality",
    "RecordSpectra",
    "RowEstimate",
    "RowLayout",
    "RowSpectra",
    "SegmentSpectra",
    "WelchSettings",
    "assess",
    "band_radius",
    "check_record",
    "check_stretches",
    "classic_estimate",
    "classic_results",
    "cross_spectra",
    "diagnose",
    "diagnose_classic",
    "diagnose_parametric",
    "diagnose_stretches",
    "element_warnings",
    "estimate_pmr",
    "estimate_sigma",
    "fitted_ratio",
    "gain_bin",
    "hamon_hannan_delay",
    "hermitian_product",
    "implicit_estimate",
    "implicit_row",
    "informative_band",
    "instrument_factor",
    "low_frequency_ratio",
    "minimum_phase",
    "parametric_results",
    "pmr_curves",
    "product",
    "readable",
    "record_spectra",
    "residual_spectra",
    "row_layout",
    "row_refusal",
    "row_regressors",
    "saturation",
    "search_limit_reason",
    "segment_spectra",
    "shortest_useful_stretch",
    "stretch_segments",
    "useful_stretches",
    "welch_of",
    "with_data_quality",
]


__getattr__, __dir__ = lazy_exports(__name__, _WHERE, __all__)


if TYPE_CHECKING:
    from .checks import MIN_SEGMENTS, InsufficientData, check_record, check_stretches
    from .classic import (
        MAX_CONDITION,
        PmrSettings,
        classic_estimate,
        classic_results,
        diagnose_classic,
        gain_bin,
        readable,
        row_refusal,
    )
    from .curves import CurveSettings, ElementCurves, band_radius, estimate_sigma, fitted_ratio, pmr_curves, welch_of
    from .data_quality import (
        QualitySettings,
        RecordQuality,
        assess,
        element_warnings,
        low_frequency_ratio,
        residual_spectra,
        saturation,
    )
    from .delay import hamon_hannan_delay, informative_band, minimum_phase, search_limit_reason
    from .diagnosis import (
        METHODS,
        diagnose,
        diagnose_stretches,
        shortest_useful_stretch,
        useful_stretches,
        with_data_quality,
    )
    from .implicit import (
        EstimateBuilder,
        PmrEstimate,
        RowEstimate,
        RowLayout,
        estimate_pmr,
        implicit_estimate,
        implicit_row,
        instrument_factor,
        row_layout,
    )
    from .parametric import ParametricSettings, diagnose_parametric, parametric_results
    from .products import hermitian_product, product
    from .regressors import row_regressors
    from .spectra import (
        RecordSpectra,
        RowSpectra,
        SegmentSpectra,
        WelchSettings,
        cross_spectra,
        record_spectra,
        segment_spectra,
        stretch_segments,
    )
