"""The monitor: rolling windows over a long record, when each parameter began to move, the trend table.

``windows`` plans the windows and cuts them as views of the one record,
``changepoint`` fits steps and ramps to overlapping window estimates (GLS),
``nochange`` simulates the threshold of the test for a change,
``onset`` decides none / step / drift with an interval on the onset time,
``trend`` lays the per-window results out as a table (CSV, Parquet) and
finds every element's onsets from it.
"""

from .onset import KINDS, Onset, OnsetSettings, detect_onset, first_lasting_mismatch, standard_errors
from .trend import (
    ELEMENT_KEYS,
    FOLLOW,
    PARAMETERS,
    delay_interval,
    onset_entries,
    trend_onsets,
    trend_table,
    write_trend,
)
from .windows import Span, parse_span, window_plan, window_views

__all__ = [
    "ELEMENT_KEYS",
    "FOLLOW",
    "KINDS",
    "PARAMETERS",
    "Onset",
    "OnsetSettings",
    "Span",
    "delay_interval",
    "detect_onset",
    "first_lasting_mismatch",
    "onset_entries",
    "parse_span",
    "standard_errors",
    "trend_onsets",
    "trend_table",
    "window_plan",
    "window_views",
    "write_trend",
]
