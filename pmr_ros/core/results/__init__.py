"""The method-neutral diagnosis result: the frozen result types, their comparison and their one codec.

:mod:`.findings` holds what one method found about one element,
:mod:`.matrix` the diagnosis of each element and of the whole model,
:mod:`.agreement` whether two diagnoses agree, and :mod:`.codec` every flat
form of them (JSON, /diagnostics KeyValues, the estimates message, the sweep
CSV row) with one spelling, each made of one part's plain values
(:mod:`.plain`).  Import the names from here.
"""

from .agreement import ABSOLUTE_TOLERANCE, DERIVED_KEYS, LATER_KEYS, RELATIVE_TOLERANCE, compare_diagnoses
from .findings import (
    KINDS,
    PROPERTIES,
    VERDICTS,
    ClassicResult,
    DataQuality,
    ElementModel,
    ImpactResult,
    Interval,
    ParametricResult,
)
from .matrix import Diagnosis, ElementDiagnosis, Part

__all__ = [
    "ABSOLUTE_TOLERANCE",
    "DERIVED_KEYS",
    "KINDS",
    "LATER_KEYS",
    "PROPERTIES",
    "RELATIVE_TOLERANCE",
    "VERDICTS",
    "ClassicResult",
    "DataQuality",
    "Diagnosis",
    "ElementDiagnosis",
    "ElementModel",
    "ImpactResult",
    "Interval",
    "ParametricResult",
    "Part",
    "compare_diagnoses",
]
