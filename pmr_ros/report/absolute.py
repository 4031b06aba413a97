"""Model against plant: each element's K, tau and D as modelled and as estimated (with intervals), in units.

The parametric diagnosis gives relative changes (dK %, dtau %, dD samples);
an engineer hands on absolute values.  ``K_plant = K_model (1 + dK/100)``
with its interval scaled the same way (sorted: a negative gain turns it
round), ``tau`` likewise, ``D_plant = D_model + dD`` in samples and in the
model's time unit.  An empty cell has no model; its plant values are the
interaction's estimate.  No estimate (the classic method, an inconclusive
fit without numbers): the plant's values are None.
"""

from __future__ import annotations

from typing import Any

from ..core.results import Diagnosis, ElementDiagnosis
from .system_units import Units

__all__ = ["absolute_table", "model_and_plant", "model_and_plant_rows"]


def _scaled(base: float | None, pct: float | None, interval: tuple[float, float] | None) -> dict[str, Any]:
    if base is None or pct is None:
        return {"value": None, "interval": None}
    bounds = None
    if interval is not None:
        low, high = (base * (1.0 + p / 100.0) for p in interval)
        bounds = [min(low, high), max(low, high)]
    return {"value": base * (1.0 + pct / 100.0), "interval": bounds}


def _plant(element: ElementDiagnosis, sample_time: float) -> dict[str, Any]:
    p, model = element.parametric, element.model
    if p is None:
        return {"gain": None, "gain_interval": None, "time_constant": None, "time_constant_interval": None,
                "delay": None, "delay_samples": None}  # fmt: skip
    if model.kind == "none":
        gain = {"value": p.unmodeled_gain, "interval": list(p.unmodeled_gain_interval or ()) or None}
        tau = {"value": None, "interval": None}
        delay = p.unmodeled_delay_samples
    else:
        gain = _scaled(model.gain, p.gain_mismatch_pct, p.gain_mismatch_pct_interval)
        tau = _scaled(model.time_constant, p.tau_mismatch_pct, p.tau_mismatch_pct_interval)
        delay = None if p.delay_mismatch_samples is None else model.delay_samples + int(p.delay_mismatch_samples)
    return {
        "gain": gain["value"],
        "gain_interval": gain["interval"],
        "time_constant": tau["value"],
        "time_constant_interval": tau["interval"],
        "delay": None if delay is None else delay * sample_time,
        "delay_samples": delay,
    }


def model_and_plant(diagnosis: Diagnosis, *, units: Units, sample_time: float) -> dict[str, dict[str, Any]]:
    """Per element: ``model`` (K, tau, D), ``plant`` (the estimates with intervals) and their ``units``.

    Parameters
    ----------
    diagnosis : Diagnosis
    units : Units
    sample_time : float
        The model's sample time [time unit]: delays in samples to time.

    Returns
    -------
    dict
        Element name to ``{"model": {...}, "plant": {...}, "units": {"gain", "time"}}``; the model
        of an empty cell is None.
    """
    out = {}
    for name, element in diagnosis.elements.items():
        model = element.model
        modelled = None
        if model.kind != "none":
            modelled = {
                "gain": model.gain,
                "time_constant": model.time_constant,
                "delay": model.delay_samples * sample_time,
                "delay_samples": model.delay_samples,
            }
        integrating = model.kind == "integrating"
        out[name] = {
            "model": modelled,
            "plant": _plant(element, sample_time),
            "units": {"gain": units.gain(element.row, element.column, integrating=integrating), "time": units.time},
        }
    return out


def _number(value: float | None, interval: list[float] | None = None) -> str:
    if value is None:
        return "-"
    text = f"{value:.4g}"
    return text + (f" [{interval[0]:.4g}, {interval[1]:.4g}]" if interval else "")


def model_and_plant_rows(values: dict[str, dict[str, Any]], *, confidence_level: float) -> list[str]:
    """The ``--wide`` table: per element K, tau and D of the model and of the estimated plant, with units."""
    level = f"{100 * confidence_level:.0f} %"
    lines = [
        f"model against estimated plant ([{level} interval]; D in the time unit, samples in parentheses):",
        f"{'element':8s} {'unit of K':18s} {'K model':>10s} {'K plant [interval]':32s} {'tau model':>10s} "
        f"{'tau plant [interval]':32s} {'D model':>10s} {'D plant':>12s}",
    ]
    for name, entry in values.items():
        m, p, unit = entry["model"] or {}, entry["plant"], entry["units"]
        d_model = "-" if not m else f"{m['delay']:g} ({m['delay_samples']})"
        d_plant = "-" if p["delay"] is None else f"{p['delay']:g} ({p['delay_samples']})"
        lines.append(
            f"{name:8s} {unit['gain'] or '-':18s} {_number(m.get('gain')):>10s} "
            f"{_number(p['gain'], p['gain_interval']):32s} {_number(m.get('time_constant')):>10s} "
            f"{_number(p['time_constant'], p['time_constant_interval']):32s} {d_model:>10s} {d_plant:>12s}"
        )
    return lines


def absolute_table(entry: dict[str, Any], *, confidence_level: float) -> dict[str, list[Any]] | None:
    """One element's model and estimated plant as a small table for the HTML page; None without an estimate.

    Returns
    -------
    dict or None
        ``header`` (K, tau, D with their units) and ``rows`` (model, estimated plant with intervals).
    """
    m, p, unit = entry["model"], entry["plant"], entry["units"]
    if p["gain"] is None:
        return None
    time = f" [{unit['time']}]" if unit["time"] else " [time unit]"
    header = ["", f"K [{unit['gain']}]" if unit["gain"] else "K", f"τ{time}", f"D{time} (samples)"]
    rows = []
    if m is not None:
        rows.append(
            ["model", _number(m["gain"]), _number(m["time_constant"]), f"{m['delay']:g} ({m['delay_samples']})"]
        )
    d_plant = "-" if p["delay"] is None else f"{p['delay']:g} ({p['delay_samples']})"
    rows.append(
        [
            f"estimated plant [{100 * confidence_level:.0f} % interval]",
            _number(p["gain"], p["gain_interval"]),
            _number(p["time_constant"], p["time_constant_interval"]),
            d_plant,
        ]
    )
    return {"header": header, "rows": rows}
