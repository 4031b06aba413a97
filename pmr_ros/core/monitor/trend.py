"""The trend table: one row per window and element (estimates, intervals, verdicts, data quality), and its onsets.

The per-window results come in as plain mappings, so that any writer of them
(today's ``ElementDiagnosis.to_dict()``, a rewritten result type, a JSON file
read back) can feed the table.  A window is a mapping with

``first``, ``last`` : int
    Its first and last sample (inclusive).
``start``, ``end`` : float, str or None
    Its clock time at those samples (seconds, or ISO 8601 text), if any.
``elements`` : mapping of name to element, or sequence of elements
    One mapping per element (a sequence's items name themselves by ``element``).
``quality`` : mapping of str to float, optional
    The window's data-quality figures (one column each, ``quality_<name>``).

and an element is a mapping with any of :data:`ELEMENT_KEYS` (a missing key is
an empty cell), read from the element itself or, failing that, from its
``parametric`` part (the ``to_dict()`` shape); its ``data_quality`` mapping, if
any, also gives ``quality_<name>`` columns.  pandas (and pyarrow for Parquet)
are the data extra's: imported when a table is made.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from .onset import OnsetSettings, detect_onset, first_lasting_mismatch, standard_errors

__all__ = [
    "DELAY_HALF_WIDTH",
    "ELEMENT_KEYS",
    "FOLLOW",
    "PARAMETERS",
    "delay_interval",
    "onset_entries",
    "trend_onsets",
    "trend_table",
    "write_trend",
]

PARAMETERS: dict[str, str] = {
    "gain": "gain_mismatch_pct",
    "tau": "tau_mismatch_pct",
    "delay": "delay_mismatch_samples",
}
"""Each parameter and its estimate's key: dK [%], dtau [%], dD [samples]; ``<key>_interval`` is its (low, high)."""

FOLLOW: dict[str, str] = {"gain": "mean", "tau": "mean", "delay": "mean"}
"""How each parameter's window estimate follows a change inside the window (:class:`OnsetSettings` ``follow``):
least squares average dK and dtau over the window, and the integer dD is the window's mean delay rounded.

A window that straddles a delay step fits one delay to a mixture of responses, and the likelihood's best
integer is the nearest to the window's mean delay (measured in ``benchmarks/bench_monitor.py year``: a +2
step on day 250 gave dD = 0 in the 14-day windows ending up to day 253, 1 from day 254, when 29 % of the
window had the new delay, and 2 from day 261, at 79 %).  So a step of two or more samples climbs in integer
stairs over one window length, which the window means of a step fit to within the rounding; read as the
window's middle value (``midpoint``), the same stairs looked like a ramp half a window early."""

ELEMENT_KEYS: tuple[str, ...] = (
    "verdict",
    *(key for parameter, value in PARAMETERS.items() for key in (value, f"{value}_interval", f"{parameter}_verdict")),
)
"""The keys of an element mapping the table reads: its verdict, and per parameter estimate, interval and verdict."""

_FIGURES = frozenset({float, int, type(None)})
"""Types of a data-quality value that make it a figure (a column), by ``type(v) in`` (no ``Sequence`` check)."""

_WINDOW_COLUMNS = ("window", "first", "last", "start", "end", "element", "verdict")
_ONSET_COLUMNS: tuple[str, ...] = ("element", "parameter", "kind", "onset", "onset_low", "onset_high", "end")
_ONSET_COLUMNS += ("size", "rate", "level", "p_value", "windows", "lasting_mismatch_window")


def _fields(element: Mapping[str, Any]) -> dict[str, Any]:
    """Each key's value: the element's, else (None or missing) its ``parametric`` part's (the ``to_dict()`` shape).

    Gathered once an element (a year's table reads 17 keys of 11,000 elements): ``.get(key)`` of the result is
    the element's value if it is not None, else the part's, else None.
    """
    part = element.get("parametric")
    values = dict(part) if type(part) is dict or isinstance(part, Mapping) else {}
    values.update({key: value for key, value in element.items() if value is not None})
    return values


def _named(elements: Mapping[str, Any] | Sequence[Mapping[str, Any]]) -> list[tuple[str, Mapping[str, Any]]]:
    """``(name, element)`` pairs from a mapping or from a sequence of self-naming elements."""
    if isinstance(elements, Mapping):
        return [(str(name), element) for name, element in elements.items()]
    return [(str(element["element"]), element) for element in elements]


DELAY_HALF_WIDTH: tuple[float, float] = (0.5, 1.5)
"""Half width of dD's 95 % interval [samples] when the element gives none (today's never does): the delay is
chosen on the integer grid, so half a sample when its profile confidence (``delay_confidence``) reaches 0.95,
one and a half (either neighbour possible) below that or when no confidence is given."""


def delay_interval(value: float | None, confidence: float | None) -> tuple[float, float] | None:
    """The 95 % interval of dD from its integer estimate and profile confidence (:data:`DELAY_HALF_WIDTH`).

    Parameters
    ----------
    value : float or None
        dD [samples].
    confidence : float or None
        Its profile-likelihood confidence against the neighbouring delays (0..1).

    Returns
    -------
    (float, float) or None
        None without an estimate.

    Examples
    --------
    >>> delay_interval(2, 0.99)
    (1.5, 2.5)
    """
    if value is None:
        return None
    sure, unsure = DELAY_HALF_WIDTH
    half = sure if confidence is not None and confidence >= 0.95 else unsure
    return float(value) - half, float(value) + half


def _interval(values: Mapping[str, Any], key: str) -> Any:
    """``<key>_interval``, else the codec's ``<key>_low``/``<key>_high``, else dD's own (:func:`delay_interval`).

    ``values``: an element's :func:`_fields`.
    """
    interval = values.get(f"{key}_interval")
    if interval is None and values.get(f"{key}_low") is not None:
        interval = (values.get(f"{key}_low"), values.get(f"{key}_high"))
    if interval is None and key == PARAMETERS["delay"]:
        interval = delay_interval(values.get(key), values.get("delay_confidence"))
    return interval


def _element_row(element: Mapping[str, Any]) -> dict[str, Any]:
    """The element's estimates, interval bounds, verdicts and per-element data quality."""
    values = _fields(element)
    row: dict[str, Any] = {"verdict": values.get("verdict")}
    for parameter, key in PARAMETERS.items():
        value, interval = values.get(key), _interval(values, key)
        low, high = (np.nan, np.nan) if interval is None else (float(interval[0]), float(interval[1]))
        row[key] = np.nan if value is None else float(value)
        row[f"{key}_low"], row[f"{key}_high"] = low, high
        row[f"{parameter}_verdict"] = values.get(f"{parameter}_verdict")
    quality = element.get("data_quality")
    if type(quality) is dict or isinstance(quality, Mapping):  # a dict, nearly always: the abstract check skipped
        # the figures, not the warnings (text, lists); a number or None decided without the abstract check
        row.update(
            {f"quality_{name}": v for name, v in quality.items() if type(v) in _FIGURES or not isinstance(v, Sequence)}
        )
    return row


def trend_table(windows: Sequence[Mapping[str, Any]]) -> Any:
    """One row per window and element, in window order.

    Parameters
    ----------
    windows : sequence of mapping
        The per-window results, in time order (keys in the module docstring).

    Returns
    -------
    pandas.DataFrame
        Columns ``window`` (0-based position), ``first``, ``last``, ``start``,
        ``end``, ``element``, ``verdict``; per parameter of :data:`PARAMETERS`
        its estimate, ``<key>_low``, ``<key>_high`` (NaN where none) and
        ``<parameter>_verdict``; then ``quality_<name>`` for every data-quality
        figure given (window-level and element-level).

    Raises
    ------
    ValueError
        A window without ``first``/``last`` or ``elements`` (named by position).
    """
    import pandas

    rows = []
    for index, window in enumerate(windows):
        missing = [key for key in ("first", "last", "elements") if key not in window]
        if missing:
            raise ValueError(f"windows[{index}]: no {', '.join(missing)}")
        head: dict[str, Any] = {"window": index, "first": int(window["first"]), "last": int(window["last"])}
        head.update(start=window.get("start"), end=window.get("end"))
        quality = {f"quality_{name}": value for name, value in (window.get("quality") or {}).items()}
        for name, element in _named(window["elements"]):
            rows.append({**head, "element": name, **_element_row(element), **quality})
    columns = [*_WINDOW_COLUMNS, *(c for c in _element_row({}) if c != "verdict")]
    table = pandas.DataFrame(rows, columns=None if rows else columns)
    extra = [c for c in table.columns if c not in columns]
    return table[[*columns, *extra]]


def write_trend(table: Any, path: str | Path) -> Path:
    """Write the trend table as CSV or Parquet, by the file's suffix.

    Parameters
    ----------
    table : pandas.DataFrame
        From :func:`trend_table`.
    path : str or Path
        ``*.csv`` or ``*.parquet``.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    ValueError
        Another suffix (the path named).
    """
    target = Path(path)
    suffix = target.suffix.lower()
    if suffix == ".csv":
        table.to_csv(target, index=False)
    elif suffix == ".parquet":
        table.to_parquet(target, index=False)
    else:
        raise ValueError(f"--trend {target}: the trend file must end in .csv or .parquet, not {suffix or 'nothing'!r}")
    return target


def _seconds(values: Any) -> np.ndarray:
    """Window times as float seconds: numbers as they are, ISO text or date-times since the epoch."""
    import pandas

    if pandas.api.types.is_numeric_dtype(values):
        return np.asarray(values, dtype=float)
    stamps = pandas.to_datetime(values, utc=True)
    return np.asarray((stamps - pandas.Timestamp(0, tz="UTC")) / pandas.Timedelta(seconds=1), dtype=float)


def _errors(rows: Any, key: str, default: float | None) -> np.ndarray:
    """Standard errors from the 95 % interval columns; ``default`` where a window has an estimate but none."""
    errors = standard_errors(low=rows[f"{key}_low"].to_numpy(), high=rows[f"{key}_high"].to_numpy())
    if default is not None:
        errors = np.where(np.isfinite(errors), errors, default)
    return errors


def _first_lasting_window(ordered: Any) -> int | None:
    """The window number from which the element's verdict stays mismatch, or None."""
    lasting = first_lasting_mismatch(list(ordered["verdict"]))
    return None if lasting is None else int(ordered["window"].iloc[lasting])


def _onset_row(element: Any, parameter: str, found: Any, first: int | None) -> dict[str, Any]:
    """One row of :func:`trend_onsets`: an element's parameter and its onset."""
    low, high = found.interval or (None, None)
    return {
        "element": element,
        "parameter": parameter,
        "kind": found.kind,
        "onset": found.time,
        "level": found.level,
    } | {
        "onset_low": low,
        "onset_high": high,
        "end": found.end,
        "size": found.size,
        "rate": found.rate,
        "p_value": found.p_value,
        "windows": found.windows,
        "lasting_mismatch_window": first,
    }


def trend_onsets(
    table: Any,
    *,
    window: float,
    time: str = "end",
    settings: OnsetSettings | None = None,
    default_errors: Mapping[str, float] | None = None,
) -> Any:
    """The onset of every element's parameters from a trend table, and the window the mismatch lasts from.

    Parameters
    ----------
    table : pandas.DataFrame
        From :func:`trend_table` (one row per window and element).
    window : float
        Window length [unit of the ``time`` column; seconds for date-times].
    time : str
        Column with each window's time: ``end`` (clock) or ``last`` (samples).
    settings : OnsetSettings, optional
        How the onsets are decided (significance ...); its ``follow`` is
        each parameter's of :data:`FOLLOW`.
    default_errors : mapping of str to float, optional
        Standard error per parameter (``gain``, ``tau``, ``delay``; its unit)
        for the windows with an estimate but no interval (the delay has none
        today): without one such windows are left out.

    Returns
    -------
    pandas.DataFrame
        One row per element and parameter: ``element``, ``parameter``,
        ``kind``, ``onset``, ``onset_low``, ``onset_high``, ``end``, ``size``,
        ``rate``, ``level``, ``p_value``, ``windows``, and ``lasting_mismatch_window``
        (the ``window`` from which the element's verdict stays mismatch, or
        None).  Onset times are in the unit of ``time`` (seconds since the
        epoch for date-times).
    """
    import pandas

    rows = []
    parsed: dict[tuple[Any, ...], np.ndarray] = {}  # the elements share their windows' times: parsed once
    for element, rows_of in table.groupby("element", sort=False):
        ordered = rows_of.sort_values("window")
        times = tuple(ordered[time].to_numpy(dtype=object))
        if times not in parsed:
            parsed[times] = _seconds(ordered[time])
        ends = parsed[times].copy()
        first = _first_lasting_window(ordered)
        for parameter, key in PARAMETERS.items():
            errors = _errors(ordered, key, (default_errors or {}).get(parameter))
            found = detect_onset(
                estimates=ordered[key].to_numpy(dtype=float),
                errors=errors,
                end_times=ends,
                window=window,
                settings=replace(settings or OnsetSettings(), follow=FOLLOW[parameter]),
            )
            rows.append(_onset_row(element, parameter, found, first))
    # a window number or none: pandas' nullable integers, not floats with NaN
    return pandas.DataFrame(rows, columns=list(_ONSET_COLUMNS)).astype({"lasting_mismatch_window": "Int64"})


def _plain(value: Any) -> Any:
    """A table cell as JSON: None for NaN / NA, Python numbers for numpy ones."""
    import pandas

    if value is None or (not isinstance(value, str) and pandas.isna(value)):
        return None
    return value.item() if isinstance(value, np.generic) else value


def onset_entries(onsets: Any) -> dict[str, dict[str, Any]]:
    """The onsets table as the JSON's ``onset`` entry per element.

    Parameters
    ----------
    onsets : pandas.DataFrame
        From :func:`trend_onsets`.

    Returns
    -------
    dict
        ``{element: {"lasting_mismatch_window": int or None, "gain": {...},
        "tau": {...}, "delay": {...}}}``, each parameter's entry with
        ``kind``, ``onset``, ``interval`` ([low, high] or None), ``end``,
        ``size``, ``rate``, ``level``, ``p_value`` and ``windows``; plain
        Python values.
    """
    entries: dict[str, dict[str, Any]] = {}
    for row in onsets.to_dict(orient="records"):
        entry = entries.setdefault(
            str(row["element"]), {"lasting_mismatch_window": _plain(row["lasting_mismatch_window"])}
        )
        low, high = _plain(row["onset_low"]), _plain(row["onset_high"])
        entry[str(row["parameter"])] = {
            "kind": row["kind"],
            "onset": _plain(row["onset"]),
            "interval": None if low is None else [low, high],
            **{key: _plain(row[key]) for key in ("end", "size", "rate", "level", "p_value", "windows")},
        }
    return entries
