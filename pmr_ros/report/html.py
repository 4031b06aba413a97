"""The HTML report of a diagnosis: one self-contained page (figures embedded) and the same figures as PNG.

``write_html_report(directory, ...)`` writes ``index.html`` and
``figures/*.png``: the matrix overview coloured by verdict, per element the
PMR magnitude and phase with the confidence band, the fitted curve, the
coherence and the informative band with the verdict and its reasons, and the
data-cleaning summary with the time plot of r, u, y and the excluded
stretches.  The page is rendered with Jinja2 (autoescaped) from
:data:`pmr_ros.report.page.TEMPLATE`.
"""

from __future__ import annotations

import base64
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..config import PmrConfig
from ..core.loop.update import NotCorrectable, corrected_model
from ..core.pmr.curves import ElementCurves, pmr_curves
from ..core.records import Record
from ..core.results import Diagnosis, ElementDiagnosis
from ..data import PlantData
from ..outputs import write_bytes, write_text
from .absolute import absolute_table
from .figures import COLOURS, element_figure, matrix_figure, time_figure
from .page import TEMPLATE
from .response_figures import prediction_figure, step_figure
from .shape_figures import differs_in_shape, shape_figure
from .system_units import units_of

__all__ = ["Figure", "ReportInput", "element_notes", "render_page", "write_html_report"]


@dataclass(frozen=True)
class ReportInput:
    """What the report shows.

    Attributes
    ----------
    report : dict
        The JSON report (:func:`pmr_ros.report.build_report`), read for the heading only: system,
        source or config, sample time, version.
    diagnosis : Diagnosis
        What the page shows: every verdict, number, reason and warning is read from it.
    stretches : sequence of Record
        The data the diagnosis read (for the spectral estimate and its band).
    data : PlantData
        The data on the sample grid with what was excluded and why.
    config : PmrConfig
    """

    report: dict[str, Any]
    diagnosis: Diagnosis
    stretches: Sequence[Record]
    data: PlantData
    config: PmrConfig


@dataclass(frozen=True)
class Figure:
    """One figure of the page: its file name, PNG bytes and caption."""

    name: str
    png: bytes
    caption: str

    @property
    def data_uri(self) -> str:
        """The PNG as a ``data:`` URI (the page needs no other file)."""
        return "data:image/png;base64," + base64.b64encode(self.png).decode("ascii")


def element_notes(element: ElementDiagnosis) -> dict[str, Any]:
    """An element's verdict, one-line summary, reasons and warnings for the page."""
    result = element.result
    warnings = list(getattr(result, "warnings", ()) or ()) if result is not None else []
    warnings += list(element.warnings)
    return {
        "name": element.name,
        "verdict": element.verdict,
        "colour": COLOURS[element.verdict],
        "summary": element.summary(),
        "reasons": list(element.all_reasons),
        "warnings": warnings,
        "mismatches": list(element.mismatches),
        "impact": None if element.impact is None else element.impact,
    }


def impact_rows(diagnosis: Diagnosis) -> list[dict[str, Any]]:
    """The mismatched elements by what they do to control (rank 1 first), for the page's impact table."""
    rows = [
        {"name": e.name, "ise": e.impact.ise_ratio, "moves": e.impact.input_movement_ratio, "rank": e.impact.rank}
        for e in diagnosis
        if e.impact is not None
    ]
    return sorted(rows, key=lambda row: row["rank"])


def _with_units(config: PmrConfig) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The CV and MV names with their units for the axes (``x_D [mol %]``); a name without a unit as it is."""
    units, model = units_of(config), config.model

    def label(names: tuple[str, ...], given: tuple[str, ...]) -> tuple[str, ...]:
        return tuple(f"{n} [{u}]" if u else n for n, u in zip(names, given, strict=True))

    return label(model.output_names, units.outputs), label(model.input_names, units.inputs)


def _figures(page: ReportInput) -> tuple[Figure, Figure, list[tuple[dict[str, Any], Figure | None]]]:
    model = page.config.model
    matrix = Figure(
        "matrix.png", matrix_figure(page.diagnosis, model.output_names, model.input_names), "Verdict per element"
    )
    timeline = Figure(
        "time.png",
        time_figure(page.data, *_with_units(page.config)),
        "Setpoints r and outputs y per CV, inputs u per MV; shaded: samples excluded from the diagnosis",
    )
    curves = pmr_curves(page.stretches, page.diagnosis, page.config)
    elements = []
    for element in page.diagnosis:
        if element.model.kind == "none":
            continue
        figure = None
        if element.name in curves:
            caption = f"{element.name}: plant-model ratio against frequency"
            figure = Figure(f"{element.name}.png", element_figure(curves[element.name], element), caption)
        notes = element_notes(element)
        values = page.report.get("model_vs_plant", {}).get(element.name)
        level = page.config.parametric.confidence_level
        notes["absolute"] = None if values is None else absolute_table(values, confidence_level=level)
        notes["step"] = _step(page, element)
        notes["shape"] = _shape(curves.get(element.name), element)
        elements.append((notes, figure))
    return matrix, timeline, elements


def _shape(curves: ElementCurves | None, element: ElementDiagnosis) -> Figure | None:
    """The plant's estimated frequency response against the best scaled model, for an element that differs in shape."""
    if curves is None or not differs_in_shape(element):
        return None
    png = shape_figure(curves, element)
    caption = (
        f"{element.name}: the plant's estimated frequency response (points, shaded: its {100 * curves.level:.0f} % "
        "band at each frequency) against the best scaled model (red: the model's gain, speed and delay changed) "
        "and the model as given (dashed); the scaled model does not follow the estimate beyond noise, so the "
        "plant differs in shape and speed and delay are not read"
    )
    return None if png is None else Figure(f"{element.name}_shape.png", png, caption)


def _step(page: ReportInput, element: ElementDiagnosis) -> Figure | None:
    """The element's step response, model against estimated plant (a D element's model is not the MPC's G: none)."""
    model = page.config.model
    if element.column >= model.n_inputs:
        return None
    units = units_of(page.config)
    integrating = element.model.kind == "integrating"
    labels = {"time": units.time, "gain": units.gain(element.row, element.column, integrating=integrating)}
    level = page.config.parametric.confidence_level
    png = step_figure(element, model.element(element.row, element.column), labels=labels, level=level)
    caption = (
        f"{element.name}: response to a unit step of {model.input_names[element.column]}, the model's and the "
        f"estimated plant's, shaded: the responses over the {100 * level:.0f} % intervals of gain and time constant"
    )
    return None if png is None else Figure(f"{element.name}_step.png", png, caption)


def _prediction(page: ReportInput) -> Figure | None:
    """Per CV, measured y against the model's and the corrected model's prediction on the longest stretch."""
    if page.diagnosis.status != "ok" or not page.stretches:
        return None
    longest = max(page.stretches, key=lambda r: r.y.shape[0])
    plant = None
    if page.diagnosis.method == "parametric":
        try:
            plant = corrected_model(page.config.model, page.diagnosis).model
        except NotCorrectable:
            plant = None
    labels = _with_units(page.config)[0]
    png = prediction_figure(longest, page.config.model, plant, labels=labels, time_unit=units_of(page.config).time)
    caption = (
        "Measured y per CV against the prediction from the measured inputs u: the model's (dashed) and the estimated "
        "plant's (the model with each mismatched element at its estimate), over the end of the longest clean "
        "stretch; below each, the model's residual y - prediction (what the inputs do not explain: setpoint-driven "
        "mismatch, unmeasured disturbances, noise)"
    )
    return None if png is None else Figure("prediction.png", png, caption)


def _counts(diagnosis: Diagnosis) -> dict[str, int]:
    counts = {"ok": 0, "mismatch": 0, "inconclusive": 0}
    for element in diagnosis:
        if element.model.kind != "none":
            counts[element.verdict] += 1
    return counts


def render_page(
    page: ReportInput, matrix: Figure, timeline: Figure, elements: list, prediction: Figure | None = None
) -> str:
    """The HTML text of the report."""
    import jinja2

    environment = jinja2.Environment(autoescape=True, undefined=jinja2.StrictUndefined)
    report = page.report
    return environment.from_string(TEMPLATE).render(
        title=f"PMR diagnosis: {report.get('system') or 'system'}",
        sample_time=units_of(page.config).time_text(page.config.model.sample_time),
        report=report,
        diagnosis=page.diagnosis,
        counts=_counts(page.diagnosis),
        colours=COLOURS,
        matrix=matrix,
        timeline=timeline,
        prediction=prediction,
        elements=elements,
        steps=page.data.steps,
        data=page.data,
        level=100 * page.config.parametric.confidence_level,
        stretches=len(page.data.stretch_bounds()),
        impact=impact_rows(page.diagnosis),
        impact_all=page.diagnosis.impact,
    )


def write_html_report(directory: str | Path, page: ReportInput) -> Path:
    """Write ``index.html`` and ``figures/*.png`` into ``directory``; the page's path.

    Raises
    ------
    OSError
        The directory cannot be written.
    """
    directory = Path(directory)
    (directory / "figures").mkdir(parents=True, exist_ok=True)
    matrix, timeline, elements = _figures(page)
    prediction = _prediction(page)
    extra = [notes[key] for notes, _ in elements for key in ("step", "shape")]
    for figure in [matrix, timeline, prediction, *(f for _, f in elements), *extra]:
        if figure is not None:
            write_bytes(directory / "figures" / figure.name, figure.png)
    index = directory / "index.html"
    write_text(index, render_page(page, matrix, timeline, elements, prediction))  # atomic: never a partial page
    return index
