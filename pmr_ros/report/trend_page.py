"""The trend page of a rolling-window diagnosis: each element's dK, dtau, dD against time, and the verdict strip.

``write_trend_page(directory, report, table)`` writes ``trend.html`` (figures
embedded as ``data:`` URIs) and ``figures/trend_*.png`` beside the report's
``index.html``: a strip of the whole controller's history (elements x
windows, coloured by verdict), then per element its three parameters against
the windows' end times with their 95 % bands, the tolerance lines and the
onset found (a line at the onset, its interval shaded).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..core.monitor import PARAMETERS
from ..outputs import write_bytes, write_text
from .figures import COLOURS, _png, _pyplot
from .html import Figure

__all__ = ["strip_figure", "tolerances", "trend_figure", "write_trend_page"]

LABELS = {"gain": "dK [%]", "tau": "dtau [%]", "delay": "dD [samples]"}
"""Axis label of each parameter."""

_VERDICTS = ("ok", "inconclusive", "mismatch", "none")


def tolerances(report: Mapping[str, Any]) -> dict[str, float]:
    """Each parameter's practical tolerance from the report's parametric settings (dD: any whole sample).

    Returns
    -------
    dict
        ``gain`` and ``tau`` [%] (absent without parametric settings), ``delay`` 0.5 [samples]: the
        integer delay differs from the model's as soon as it is off by one.
    """
    settings = (report.get("settings") or {}).get("parametric") or {}
    out = {"delay": 0.5}
    for parameter in ("gain", "tau"):
        if settings.get(f"{parameter}_tolerance_pct") is not None:
            out[parameter] = float(settings[f"{parameter}_tolerance_pct"])
    return out


def _times(values: Any) -> tuple[np.ndarray, str]:
    """Window end times for the x axis: date-times, or hours since sample 0; and the axis label."""
    import pandas

    if pandas.api.types.is_numeric_dtype(values):
        return np.asarray(values, dtype=float) / 3600.0, "time [h]"
    return pandas.DatetimeIndex(pandas.to_datetime(values, utc=True)).tz_localize(None).to_numpy(), "window end (UTC)"


def _onset_time(value: Any, dated: bool) -> Any:
    import pandas

    if value is None:
        return None
    return pandas.Timestamp(value).tz_localize(None) if dated else float(value) / 3600.0


def _mark_onset(axes: Any, found: Mapping[str, Any] | None, dated: bool) -> None:
    """The onset as a dashed line, its interval shaded, labelled by the kind (step or drift)."""
    if not found or found.get("kind") not in ("step", "drift"):
        return
    axes.axvline(_onset_time(found["onset"], dated), color="#6a1b9a", linestyle="--", label=f"{found['kind']} onset")
    if found.get("interval"):
        low, high = (_onset_time(t, dated) for t in found["interval"])
        axes.axvspan(low, high, color="#ce93d8", alpha=0.35)


def trend_figure(rows: Any, *, onset: Mapping[str, Any] | None, limits: Mapping[str, float], name: str) -> bytes:
    """One element's dK, dtau, dD against the window end times with 95 % bands, tolerances and onsets, as PNG.

    Parameters
    ----------
    rows : pandas.DataFrame
        The element's rows of the trend table (:func:`pmr_ros.core.monitor.trend_table`).
    onset : mapping or None
        Its ``onset`` entry (:func:`pmr_ros.core.monitor.onset_entries` with times as the windows').
    limits : mapping
        Tolerance per parameter (:func:`tolerances`).
    name : str
        The element (title).
    """
    plt = _pyplot()
    fig, axes = plt.subplots(3, 1, figsize=(10, 6.6), sharex=True)
    times, label = _times(rows["end"])
    dated = label.startswith("window")
    for ax, (parameter, key) in zip(axes, PARAMETERS.items(), strict=True):
        ax.fill_between(times, rows[f"{key}_low"], rows[f"{key}_high"], color="#bbdefb", label="95 % interval")
        ax.plot(times, rows[key], color="#1565c0", marker=".", markersize=3, linewidth=1, label="window estimate")
        if parameter in limits:
            for sign in (-1, 1):
                ax.axhline(sign * limits[parameter], color="#c62828", linewidth=0.8, linestyle=":")
        ax.axhline(0.0, color="#9e9e9e", linewidth=0.6)
        _mark_onset(ax, (onset or {}).get(parameter), dated)
        ax.set_ylabel(LABELS[parameter])
        ax.grid(True, alpha=0.3)
    axes[0].set_title(f"{name}: mismatch per window (dotted: tolerance)")
    axes[0].legend(loc="upper left", fontsize=8)
    axes[-1].set_xlabel(label)
    fig.autofmt_xdate()
    fig.tight_layout()
    return _png(fig)


def strip_figure(table: Any) -> bytes:
    """Elements x windows, each cell coloured by the element's verdict in that window, as PNG."""
    from matplotlib.colors import ListedColormap

    plt = _pyplot()
    elements = list(dict.fromkeys(table["element"]))
    windows = int(table["window"].max()) + 1 if len(table) else 0
    codes = np.full((len(elements), windows), _VERDICTS.index("none"))
    row_of = {name: i for i, name in enumerate(elements)}
    for element, window, verdict in zip(table["element"], table["window"], table["verdict"], strict=True):
        codes[row_of[element], int(window)] = _VERDICTS.index(verdict) if verdict in _VERDICTS else 3
    fig, ax = plt.subplots(figsize=(10, 0.9 + 0.32 * len(elements)))
    cmap = ListedColormap([COLOURS[v] for v in _VERDICTS])
    ax.imshow(codes, aspect="auto", interpolation="nearest", cmap=cmap, vmin=-0.5, vmax=len(_VERDICTS) - 0.5)
    ax.set_yticks(range(len(elements)), elements)
    ax.set_xlabel("window (time order)")
    ax.set_title("Verdict per element and window: green ok, amber inconclusive, red mismatch, grey none")
    fig.tight_layout()
    return _png(fig)


_TEMPLATE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{{ title }}</title>
<style>
 body { font-family: system-ui, sans-serif; margin: 0 auto; max-width: 1100px; padding: 1.2em; color: #212121; }
 figure img { max-width: 100%; height: auto; border: 1px solid #eeeeee; }
 figcaption, .meta { color: #616161; font-size: 0.9em; }
 td, th { border: 1px solid #e0e0e0; padding: 0.3em 0.6em; } table { border-collapse: collapse; }
</style></head><body>
<h1>{{ title }}</h1>
<p class="meta">{{ windows }} windows of {{ monitor.window }} stepped by {{ monitor.step }} &middot;
 <a href="index.html">the last window's report</a></p>
<h2>History</h2>
<figure><img src="{{ strip.data_uri }}" alt="verdict strip"><figcaption>{{ strip.caption }}</figcaption></figure>
<h2>Onsets</h2>
<table><tr><th>element</th><th>parameter</th><th>kind</th><th>onset</th><th>95 % interval</th></tr>
{% for row in onsets %}<tr><td>{{ row[0] }}</td><td>{{ row[1] }}</td><td>{{ row[2] }}</td><td>{{ row[3] }}</td>
<td>{{ row[4] }}</td></tr>{% else %}<tr><td colspan="5">no parameter moved</td></tr>{% endfor %}
</table>
{% for figure in figures %}<h2>{{ figure.name[6:-4] }}</h2>
<figure><img src="{{ figure.data_uri }}" alt="{{ figure.caption }}"><figcaption>{{ figure.caption }}</figcaption>
</figure>{% endfor %}
</body></html>
"""


def _onset_rows(report: Mapping[str, Any]) -> list[tuple[str, str, str, str, str]]:
    rows = []
    for name, element in (report.get("elements") or {}).items():
        for parameter in PARAMETERS:
            found = (element.get("onset") or {}).get(parameter) or {}
            if found.get("kind") in ("step", "drift"):
                low, high = found.get("interval") or ("-", "-")
                rows.append((name, parameter, found["kind"], str(found["onset"]), f"{low} .. {high}"))
    return rows


def write_trend_page(directory: str | Path, report: Mapping[str, Any], table: Any) -> Path:
    """Write ``trend.html`` and ``figures/trend_*.png`` into ``directory``; the page's path.

    Parameters
    ----------
    directory : str or Path
        The report's folder (beside ``index.html``).
    report : mapping
        The JSON report with ``monitor`` and each element's ``onset``.
    table : pandas.DataFrame
        The trend table.

    Raises
    ------
    OSError
        The directory cannot be written.
    """
    import jinja2

    directory = Path(directory)
    (directory / "figures").mkdir(parents=True, exist_ok=True)
    limits = tolerances(report)
    elements = report.get("elements") or {}
    strip = Figure("trend_strip.png", strip_figure(table), "Each row an element, each column a window")
    figures = []
    for name, rows in table.groupby("element", sort=False):
        onset = (elements.get(name) or {}).get("onset")
        png = trend_figure(rows.sort_values("window"), onset=onset, limits=limits, name=str(name))
        caption = f"{name}: dK, dtau and dD per window with 95 % bands; dashed: onset, shaded: its interval"
        figures.append(Figure(f"trend_{name}.png", png, caption))
    for figure in [strip, *figures]:
        write_bytes(directory / "figures" / figure.name, figure.png)
    html = jinja2.Environment(autoescape=True, undefined=jinja2.StrictUndefined).from_string(_TEMPLATE)
    page = directory / "trend.html"
    title = f"PMR trend: {report.get('system') or 'system'}"
    monitor = report.get("monitor") or {"window": "?", "step": "?"}
    text = html.render(
        title=title,
        windows=int(table["window"].nunique()),
        monitor=monitor,
        strip=strip,
        figures=figures,
        onsets=_onset_rows(report),
    )
    write_text(page, text)
    return page
