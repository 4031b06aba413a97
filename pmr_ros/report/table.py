"""The verdict table people read in a terminal, rendered from the :class:`Diagnosis` itself.

Every number, verdict, reason and warning comes from the diagnosis object;
the JSON report (:func:`pmr_ros.report.build_report`) gives only the heading:
what was diagnosed, where it came from, the confidence level and, for a
simulated run, the injected mismatch.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

from ..core.results import ClassicResult, Diagnosis, ElementDiagnosis, ImpactResult, ParametricResult
from .absolute import model_and_plant_rows

__all__ = ["format_classic_table", "format_parametric_table", "format_table", "grouped_notes", "summary_line"]

MARKS = {"ok": "", "mismatch": "!", "inconclusive": "?"}
"""Table marks of a parameter's verdict."""

Injected = Mapping[str, Mapping[str, Any]]
"""Element name to the injected ``gain_pct``, ``time_constant_pct`` and ``delay_samples`` (a report's ``injected``)."""


def _interval(value: float | None, interval: tuple[float, float] | None) -> str:
    if value is None or interval is None:
        return "-"
    return f"{value:+6.1f} [{interval[0]:+6.1f},{interval[1]:+6.1f}]"


def _injected(injected: Injected, name: str) -> str:
    t = injected.get(name)
    if t is None:  # an element the truth does not name (a D element of a run without a DV mismatch)
        return " -"
    return f" {t['gain_pct']:+.0f}, {t['time_constant_pct']:+.0f}, {t['delay_samples']:+d}"


def _delay_text(samples: int | None, confidence: float | None, verdict: str | None) -> str:
    if samples is None or confidence is None:
        return "-"
    return f"{samples:+d} ({100 * confidence:.0f} %)" + MARKS.get(verdict or "ok", "")


def _parametric_line(element: ElementDiagnosis) -> str:
    p = element.parametric if element.parametric is not None else _NO_FIT
    name = element.name
    if element.model.kind == "none":
        return _interaction_line(element, p)
    gain = _interval(p.gain_mismatch_pct, p.gain_mismatch_pct_interval) + MARKS[p.gain_verdict or "ok"]
    tau = "-"  # an integrating element has no time constant
    if p.tau_verdict is not None or p.tau_mismatch_pct is not None:
        tau = _interval(p.tau_mismatch_pct, p.tau_mismatch_pct_interval) + MARKS[p.tau_verdict or "ok"]
    delay = _delay_text(p.delay_mismatch_samples, p.delay_confidence, p.delay_verdict)
    return f"{name:8s} {gain:26s} {tau:26s} {delay:16s} {element.verdict:13s} {_impact(element.impact):11s}"


_NO_FIT = ParametricResult(gain_verdict=None, tau_verdict=None, delay_verdict=None)
"""What the table shows of an element without a parametric result: no numbers, no marks."""


def _impact(impact: ImpactResult | None) -> str:
    """``x1.23 (#1)``: the ISE ratio and rank of an element's mismatch, or nothing."""
    if impact is None:
        return ""
    return f"x{impact.ise_ratio:.2f} (#{impact.rank})" if impact.rank else f"x{impact.ise_ratio:.2f}"


CONTROLLERS = {"mpc": "configured MPC", "pi": "configured PI loops"}
"""The simulated controller of the impact in words, by ``controller.kind``."""


def _impact_lines(diagnosis: Diagnosis, controller: str = "mpc") -> list[str]:
    together = diagnosis.impact
    if together is None:
        return []
    return [
        f"control impact ({CONTROLLERS.get(controller, controller)}, noise-free, plant as estimated vs as modelled): "
        "all together ISE "
        f"x{together.ise_ratio:.2f}, input moves x{together.input_movement_ratio:.2f}; "
        "per element: ISE ratio with that mismatch alone (#1 matters most)"
    ]


def _interaction_line(element: ElementDiagnosis, p: ParametricResult) -> str:
    """An empty cell: the gain [interval] and delay of the plant's interaction there, across the dK and dtau columns."""
    gain, interval = p.unmodeled_gain, p.unmodeled_gain_interval
    text = "no model, not tested"
    if gain is not None and interval is not None:
        mark = MARKS[p.unmodeled_verdict or "ok"]
        text = f"no model: K {gain:+.3g} [{interval[0]:+.3g},{interval[1]:+.3g}]{mark}"
    delay = _delay_text(p.unmodeled_delay_samples, p.delay_confidence, None)
    delay = delay if gain is not None and p.unmodeled_verdict == "mismatch" else "-"
    return f"{element.name:8s} {text:53s} {delay:16s} {element.verdict:13s} {_impact(element.impact):11s}"


def _notes(element: ElementDiagnosis, result: ClassicResult | ParametricResult | None) -> list[tuple[str, str]]:
    """``(element, text)``: the element's reasons, its method's reasons and warnings, then its data-quality warnings."""
    texts = [*element.reasons, *(result.reasons if result is not None else ())]
    texts += [*getattr(result, "warnings", ()), *element.warnings]
    return [(element.name, text) for text in texts]


NAMES_SHOWN = 6
"""Elements named on a grouped note's line; the others are counted."""

_FIGURE = re.compile(r"(?<![A-Za-z_\d.])[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?")
"""A figure in a note; not the digits of a name (u4, G1_4, XI101.PV): notes on different channels stay apart."""


def _names(names: list[str]) -> str:
    shown = ", ".join(names[:NAMES_SHOWN])
    return shown + (f" and {len(names) - NAMES_SHOWN} more" if len(names) > NAMES_SHOWN else "")


def grouped_notes(notes: list[tuple[str, str]]) -> list[str]:
    """One line per kind of note, with how many elements it concerns and which, in order of first appearance.

    Notes of one kind differ only in their figures (``row 3 mixes time constants 1.9x apart``, ``row 15 ... 2.1x``),
    not in the channels they name: a kind whose texts are all equal shows the text, else its first text as an
    example.

    Examples
    --------
    >>> grouped_notes([("G11", "u1 at a limit"), ("G21", "u1 at a limit"), ("G12", "row 1 slow")])
    ['G11, G21 (2 elements): u1 at a limit', 'G12: row 1 slow']
    """
    kinds: dict[str, list[tuple[str, str]]] = {}
    for name, text in notes:
        kinds.setdefault(_FIGURE.sub("#", text), []).append((name, text))
    lines = []
    for members in kinds.values():
        names = list(dict.fromkeys(name for name, _ in members))
        name, text = members[0]
        if len({text for _, text in members}) > 1:
            text = f"{text} (e.g. {name}; figures per element in --json)"
        lines.append(f"{_names(names)} ({len(names)} elements): {text}" if len(names) > 1 else f"{names[0]}: {text}")
    return lines


def summary_line(diagnosis: Diagnosis) -> str:
    """``summary: 1 mismatch, 0 inconclusive, 3 ok of 4 modeled elements``: the verdict counts in one line.

    Empty cells are counted apart (:meth:`~pmr_ros.core.results.Diagnosis.verdict_counts`).
    """
    return f"summary: {diagnosis.verdict_counts()}"


def format_parametric_table(
    diagnosis: Diagnosis, *, confidence_level: float, injected: Injected | None = None, controller: str = "mpc"
) -> str:
    """The parametric method's table: estimates with intervals and verdicts, then the reasons.

    ``confidence_level`` of the intervals [0..1]; ``injected`` adds the truth of a simulated run;
    ``controller`` (``controller.kind``) names the controller the impact simulated.
    """
    level = 100 * confidence_level
    cols = (
        f"{'element':8s} {'dK % [' + f'{level:.0f} % interval]':26s} {'dtau % [interval]':26s} "
        f"{'dD (confidence)':16s} {'verdict':13s} {'impact ISE':11s}"
    )
    lines = [cols + (" injected dK %, dtau %, dD" if injected else "")]
    notes = []
    for e in diagnosis:
        lines.append(_parametric_line(e) + (_injected(injected, e.name) if injected else ""))
        notes += _notes(e, e.parametric)
    lines.append("")
    lines.append("! mismatch (whole interval beyond the tolerance), ? inconclusive; dD = D - Dhat [samples]")
    if any(e.model.kind == "none" for e in diagnosis):
        lines.append(
            "no model: an empty cell; K [interval] and delay of the plant's interaction there (! one the model lacks)"
        )
    lines += _impact_lines(diagnosis, controller)
    lines += grouped_notes(notes)
    return "\n".join(lines) + "\n"


def _classic_line(element: ElementDiagnosis) -> str:
    c, name = element.classic, element.name
    if c is None:
        return f"{name:8s} {'-':>10s}  {'-':14s} {'-':>9s}  {'-':15s} {'-':>5s}  {element.verdict:9s}"
    gain = f"{100 * (c.gain_ratio - 1):+.1f} % {c.gain_direction}" if c.gain_mismatch else "ok"
    if c.tau_index is None:
        index, tau = f"{'-':>9s}", "-"
    else:
        index = f"{c.tau_index:+9.1f}"
        tau = ("larger" if c.tau_index > 0 else "smaller") if c.tau_mismatch else "ok"
    return (
        f"{name:8s} {c.gain_ratio:10.3f}  {gain:14s} {index}  {tau:15s} "
        f"{c.delay_mismatch_samples:+5d}  {element.verdict:9s}"
    )


def format_classic_table(diagnosis: Diagnosis, *, injected: Injected | None = None) -> str:
    """The classic method's table: gain ratio, tau index, delay and the flags (``injected``: the simulated truth)."""
    cols = (
        f"{'element':8s} {'gain ratio':>10s}  {'gain':14s} {'tau index':>9s}  {'time constant':15s} {'delay':>5s}  "
        f"{'verdict':9s}"
    )
    lines = [cols + ("  injected dK %, dtau %, dD" if injected else "")]
    notes = []
    for e in diagnosis:
        lines.append(_classic_line(e) + (" " + _injected(injected, e.name) if injected else ""))
        notes += _notes(e, e.classic)
    lines.append("")
    lines.append(
        "gain ratio = K/Khat from M(0); tau index = -100 x slope of M(w)/M(0) on (0, tau_band], > 0: plant slower; "
        "delay = D - Dhat [samples]"
    )
    lines += grouped_notes(notes)
    return "\n".join(lines) + "\n"


def format_table(diagnosis: Diagnosis, report: Mapping[str, Any], *, wide: bool = False) -> str:
    """The verdict table of a diagnosis, one line per element, headed by what was diagnosed.

    Parameters
    ----------
    diagnosis : Diagnosis
        What the table shows.
    report : mapping
        The JSON report of it (:func:`pmr_ros.report.build_report`), read for the heading only:
        ``system``, ``command``, ``source`` or ``scenario``/``seed``, ``settings.parametric.confidence_level``
        and ``injected``; with ``wide`` its ``model_vs_plant``.
    wide : bool
        Also the table of the model's and the estimated plant's K, tau and D side by side (``--wide``).
    """
    origin = report.get("source") or f"scenario {report['scenario']}, seed {report['seed']}"
    head = (
        f"{report['system'] or 'system'}: {report['command']} ({diagnosis.method} PMR), {origin}, "
        f"{diagnosis.samples} samples"
    )
    if diagnosis.status != "ok":
        return f"{head}\nINSUFFICIENT DATA: {diagnosis.reason}\n"
    injected = report.get("injected")
    if diagnosis.method == "parametric":
        level = report["settings"]["parametric"]["confidence_level"]
        body = format_parametric_table(
            diagnosis, confidence_level=level, injected=injected, controller=report.get("controller", "mpc")
        )
    else:
        body = format_classic_table(diagnosis, injected=injected)
    if wide and diagnosis.method == "parametric":
        values = report.get("model_vs_plant", {})
        level = report["settings"]["parametric"]["confidence_level"]
        body += "\n" + "\n".join(model_and_plant_rows(values, confidence_level=level)) + "\n"
    return f"{head}\n\n{body}{summary_line(diagnosis)}\n"
