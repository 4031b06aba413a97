"""A bag diagnosed offline as the live diagnostician did, compared with the verdicts it recorded, and its last window.

The replay itself (the bag's r, u, y through the live node's aligner and
schedule) is :mod:`pmr_ros.bag.offline`; this flow adds the configuration the
bag is judged with, the comparison with the recorded /diagnostics (with the
control impact when the live node computed one: :mod:`pmr_ros.service.closing`)
and the data of the last diagnosed window for the HTML report.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from ..bag.disturbances import config_disturbances, disturbance_topic
from ..bag.offline import (
    OfflineResult,
    RecordedVerdict,
    bag_configuration,
    bag_namespace,
    check_system,
    held_samples,
    recorded_verdicts,
    replay_bag,
    required_topics,
)
from ..bag.reader import Bag
from ..bag.storage import BagError
from ..config import PmrConfig
from ..config.controller_block import foreign_controller
from ..config.schema import parameter
from ..contract.alignment import MANUAL
from ..contract.layout import read_signal
from ..contract.samples import sample_index
from ..contract.topics import SIGNAL_TOPICS, topic
from ..contract.windowing import VERDICT, WindowOutcome, window_dither
from ..core.records import Record
from ..core.results import Diagnosis, compare_diagnoses
from ..core.results.codec import diagnosis_to_json
from ..data import PlantData
from .closing import close_diagnosis

__all__ = ["bag_record", "compare", "diagnose_bag", "judged_config", "window_data", "window_signals"]


def judged_config(
    config: PmrConfig, *, held: int, origin: str, min_samples: int | None = None
) -> tuple[PmrConfig, str | None]:
    """The configuration a bag is judged with offline, and a note when it differs from the recorded one.

    ``min_samples`` (``--min-samples``) replaces ``diagnostician.min_samples``.
    Without it, a ``pmr-ros run --bag`` recording (its minimum is the run's
    planned length: ``min_samples == window_samples == run.samples``) that
    holds fewer samples than planned is judged with the declared default
    minimum instead: the recording was cut short, the data may still do.

    Raises
    ------
    BagError
        ``min_samples`` exceeds the window.
    """
    settings = config.diagnostician
    if min_samples is not None:
        if min_samples > settings.window_samples:
            raise BagError(
                f"--min-samples {min_samples}: must not exceed diagnostician.window_samples = "
                f"{settings.window_samples} of the configuration ({origin})"
            )
        return replace(config, diagnostician=replace(settings, min_samples=min_samples)), None
    planned = config.run.samples
    if not (settings.min_samples == settings.window_samples == planned and held < planned):
        return config, None
    cut = f"the bag holds {held} of the {planned} samples its run planned (a recording cut short)"
    default = int(parameter("diagnostician.min_samples").default)
    if default >= planned:
        return config, f"{cut}; --min-samples N judges it on fewer samples"
    note = (
        f"{cut}: judged with diagnostician.min_samples = {default} (the declared default) instead of the planned "
        "length; --min-samples N to require more or fewer"
    )
    return replace(config, diagnostician=replace(settings, min_samples=default)), note


def diagnose_bag(
    bag: Bag,
    config_path: str | None = None,
    method: str | None = None,
    *,
    min_samples: int | None = None,
    namespace: str | None = None,
) -> OfflineResult:
    """Diagnose a bag offline as the live diagnostician did, and compare with its recorded verdicts.

    ``method`` (``classic`` or ``parametric``) overrides the configuration's
    ``pmr.method``; recorded verdicts made with another method are not
    compared.  ``min_samples`` overrides ``diagnostician.min_samples`` (see
    :func:`judged_config` for a recording cut short).  ``namespace`` picks the
    node set whose topics are read (default: the one the bag recorded, see
    :func:`bag_namespace`).

    Raises
    ------
    BagError
        A needed topic is missing, empty or of the wrong type, no
        configuration, or one whose channels are not the bag's.
    """
    config, origin, namespace = _checked_config(bag, config_path, method, namespace)
    config, note = judged_config(config, held=held_samples(bag, namespace), origin=origin, min_samples=min_samples)
    replay = replay_bag(bag, config, namespace)
    end_of_bag = replay.finish()
    result = OfflineResult(
        config,
        origin,
        replay.outcomes,
        recorded_verdicts(bag, config, namespace),
        warnings=replay.warnings,
        messages=replay.counts,
        end_of_bag=end_of_bag,
        drops=replay.drops,
        gaps=replay.aligner.gaps,
        notes=[note] if note else [],
        namespace=namespace,
    )
    result.comparisons = compare(result.outcomes, result.recorded, config.pmr.method, config=config)
    others = sorted({v.diagnosis.method for v in result.recorded if v.diagnosis.status == "ok"} - {config.pmr.method})
    if others:
        result.warnings.insert(
            0,
            f"verdicts recorded with the {', '.join(others)} method are not compared with these ({config.pmr.method})",
        )
    return result


def _with_impact(recorded: Diagnosis, mine: Diagnosis, config: PmrConfig | None) -> Diagnosis:
    """The offline diagnosis with its control impact when the live node recorded one (the same computation)."""
    has_impact = recorded.impact is not None or any(e.impact is not None for e in recorded)
    return close_diagnosis(mine, config).diagnosis if has_impact and config is not None else mine


def _without_impact(elements: dict[str, Any]) -> dict[str, Any]:
    return {name: {k: v for k, v in e.items() if k != "impact"} for name, e in elements.items()}


def _comparison(verdict: RecordedVerdict, mine: WindowOutcome | None, config: PmrConfig | None) -> dict[str, Any]:
    """One recorded verdict against the offline outcome of its window."""
    first, last = verdict.window or (0, 0)
    entry: dict[str, Any] = {"first_sample": first, "last_sample": last, "recorded_status": verdict.diagnosis.status}
    if mine is None:
        entry.update(equal=False, offline_status="not diagnosed offline")
        return entry
    entry["offline_status"] = "ok" if mine.kind == VERDICT else mine.kind
    if mine.kind != VERDICT:
        entry["equal"] = False
        return entry
    offline = _with_impact(verdict.diagnosis, mine.diagnosis, config)
    recorded, judged = diagnosis_to_json(verdict.diagnosis)["elements"], diagnosis_to_json(offline)["elements"]
    if offline.impact is None and all(e.impact is None for e in offline):
        # no impact offline (impact.samples 0, an external controller): the verdicts are compared, not the figures
        recorded, judged = _without_impact(recorded), _without_impact(judged)
    entry["differences"] = compare_diagnoses(recorded, judged)
    entry["equal"] = not entry["differences"]
    return entry


def compare(
    outcomes: list[WindowOutcome],
    recorded: list[RecordedVerdict],
    method: str | None = None,
    *,
    config: PmrConfig | None = None,
) -> list[dict[str, Any]]:
    """For every verdict the live node recorded for a window, whether the offline one for that window agrees.

    Only the live node's verdicts are compared: a window it could not
    diagnose (stale while its publishers matched, too few samples) is no
    disagreement, whatever the offline diagnosis of it.  With ``method``,
    verdicts made with another method are left out.  Agreeing means an
    offline verdict for the same window in which
    :func:`~pmr_ros.core.results.compare_diagnoses` finds no difference:
    verdicts, flags, delays and strings equal, floats within its tolerance
    (the same data diagnosed on another machine differ in the last digits).
    With ``config``, a recorded verdict that carries the control impact is
    compared with the offline one's, computed the same way.
    """
    offline = {}
    for outcome in outcomes:
        if "first_sample" in outcome.window:
            offline[(outcome.window["first_sample"], outcome.window["last_sample"])] = outcome
    out = []
    for verdict in recorded:
        window = verdict.window
        if window is None or verdict.diagnosis.status != "ok":
            continue
        if method is not None and verdict.diagnosis.method != method:
            continue
        out.append(_comparison(verdict, offline.get(window), config))
    return out


def window_signals(bag: Bag, result: OfflineResult) -> tuple[dict[str, np.ndarray], int] | None:
    """r, u, y (and ``dv``, as replayed) of the last diagnosed window of a bag, in channel order, and its first sample.

    Each message goes to the sample its stamp names
    (:func:`~pmr_ros.contract.samples.sample_index`, as the aligner places
    it); a sample no message filled stays NaN.  None when no window was diagnosed.
    """
    window = result.final.window if result.final is not None else {}
    if "first_sample" not in window:
        return None
    model = result.config.model
    first, samples = int(window["first_sample"]), int(window["window_samples"])
    names, by_topic = _channels(bag, result.config, result.namespace)
    signals = {s: np.full((samples, len(n)), np.nan) for s, n in names.items()}
    for message in bag.messages(set(by_topic)):
        signal = by_topic[message.topic]
        stamp, channels, values = read_signal(bag.decode(message))
        k = sample_index(stamp, model.sample_time)[0] - first
        if 0 <= k < samples and tuple(channels) == names[signal] and values.size == len(channels):
            signals[signal][k] = values
    return signals, first


def window_data(bag: Bag, result: OfflineResult) -> tuple[PlantData, list[Record]] | None:
    """The last diagnosed window as plant data and as the record the report's curves read (with its dither).

    None when no window of the bag was diagnosed.
    """
    found = window_signals(bag, result)
    if found is None:
        return None
    window, first = found
    config = result.config
    data = PlantData.from_record(
        window, source=str(bag.path), sample_time_s=config.model.sample_time, start=f"sample {first}"
    )
    dither = window_dither(config, first, data.samples)
    return data, [Record(window["r"], window["u"], window["y"], dither, window.get("dv"))]


def _channels(bag: Bag, config: PmrConfig, namespace: str) -> tuple[dict[str, tuple[str, ...]], dict[str, str]]:
    """The channels of each signal the bag gives (r, u, y and, when configured and recorded, dv) and their topics."""
    model = config.model
    names = {"r": model.output_names, "u": model.input_names, "y": model.output_names}
    by_topic = {topic(SIGNAL_TOPICS[s]).resolved(namespace): s for s in names}
    dv = disturbance_topic(bag, config, namespace)
    if dv is not None:
        names["dv"], by_topic[dv] = config_disturbances(config), "dv"
    return names, by_topic


def _placed(bag: Bag, config: PmrConfig, namespace: str) -> list[tuple[str, int, np.ndarray]]:
    """Every r, u, y (and dv) message of the node set as ``(signal, sample, values)``, channels in configured order."""
    model = config.model
    names, by_topic = _channels(bag, config, namespace)
    placed = []
    for message in bag.messages(set(by_topic)):
        signal = by_topic[message.topic]
        decoded = bag.decode(message)
        stamp, channels, values = read_signal(decoded)
        if tuple(channels) == names[signal] and values.size == len(channels):
            k = sample_index(stamp, model.sample_time)[0]
            placed.append((signal, k, np.asarray(values, dtype=float)))
            marks = np.asarray(getattr(decoded, "effort", ()), dtype=float)
            if signal == "u" and marks.size == values.size and np.any(marks > 0.5):  # the modes marked on u
                placed.append((MANUAL, k, marks > 0.5))
    return placed


def bag_record(
    bag: Bag, config_path: str | None = None, method: str | None = None, *, namespace: str | None = None
) -> tuple[PlantData, PmrConfig]:
    """The bag's whole r, u, y (dither, DVs) on the sample grid, read once, and the configuration to judge it with.

    Each message goes to the sample its stamp names (as the aligner places
    it); a sample no message filled is missing.  The measured disturbances
    come in when the configuration declares them and the bag holds their
    topic (:func:`~pmr_ros.bag.disturbances.disturbance_topic`), as in the
    whole-bag replay: every sample then needs them.  Sample 0 of the data is the
    first stamped sample; ``start`` is its time (ISO, from the stamps).

    Raises
    ------
    BagError
        A needed topic is missing, no configuration, channels that are not the bag's, no r, u, y message.
    """
    import pandas

    config, origin, namespace = _checked_config(bag, config_path, method, namespace)
    placed = _placed(bag, config, namespace)
    if not placed:
        raise BagError(f"{bag.path}: no r, u, y message of the configuration's channels to diagnose")
    first = min(k for _, k, _ in placed)
    samples = max(k for _, k, _ in placed) - first + 1
    model = config.model
    names, _ = _channels(bag, config, namespace)
    signals = {s: np.full((samples, len(n)), np.nan) for s, n in names.items()}
    manual = np.zeros((samples, model.n_inputs), dtype=bool)
    for signal, k, values in placed:
        if signal == MANUAL:
            manual[k - first] = values
        else:
            signals[signal][k - first] = values
    dither = window_dither(config, first, samples)
    if dither is not None:
        signals["dither"] = np.where(manual, 0.0, dither)  # a controller that is off adds no dither
    start = pandas.Timestamp(first * model.sample_time, unit="s", tz="UTC").isoformat()
    data = PlantData.from_record(
        signals, source=str(bag.path), sample_time_s=model.sample_time, start=start, manual=manual
    )
    return data, config


def _checked_config(
    bag: Bag, config_path: str | None, method: str | None, namespace: str | None
) -> tuple[PmrConfig, str, str]:
    """The configuration a bag is judged with (its channels checked against the bag's), its origin, the namespace."""
    namespace = bag_namespace(bag) if namespace is None else namespace
    bag.require(required_topics(namespace))
    config, origin = bag_configuration(bag, config_path)
    if origin != "bag" and bag.run_config() is None:  # another controller's bag: not this tool's MPC
        config = foreign_controller(config)
    check_system(bag, config, origin, namespace)
    if method is not None:
        config = replace(config, pmr=replace(config.pmr, method=method))
    return config, origin, namespace
