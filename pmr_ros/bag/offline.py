"""Offline diagnosis of a bag: the live diagnostician's alignment and windows, without ROS.

The recorded r, u and y messages go, in recording order, through the same
:class:`~pmr_ros.contract.alignment.SampleAligner` and the same update schedule and
window evaluation (:mod:`pmr_ros.contract.windowing`) as in the live
``pmr_diagnostician``, with the model, PMR settings and diagnostician window
of the recorded configuration (or of ``--config``).  Every window the live
node diagnosed is diagnosed again, and the verdicts recorded on /diagnostics
are compared with the offline ones number for number.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

from ..config import PmrConfig, load_config, parse_config
from ..contract.alignment import SIGNALS, SampleAligner
from ..contract.layout import diagnosis_from_array, read_signal
from ..contract.topics import SIGNAL_TOPICS, namespaces_of, topic
from ..contract.windowing import VERDICT, WindowOutcome, evaluate_window, offer_signal
from ..core.results import Diagnosis, compare_diagnoses
from .reader import Bag
from .schema import BagError

DIAGNOSTICIAN_NODE = "pmr_diagnostician"
"""Name of the live diagnostician whose recorded statuses are compared."""


@dataclass
class RecordedVerdict:
    """One /diagnostics message of the bag, decoded.

    Attributes
    ----------
    diagnosis : Diagnosis
    info : dict
        Levels, messages, ``window_samples``, ``first_sample``, ``last_sample``.
    """

    diagnosis: Diagnosis
    info: dict[str, Any]

    @property
    def window(self) -> tuple[int, int] | None:
        """``(first_sample, last_sample)`` of the diagnosed window, if the status names one."""
        if "first_sample" not in self.info:
            return None
        return int(self.info["first_sample"]), int(self.info["last_sample"])


@dataclass
class OfflineResult:
    """Everything the offline diagnosis of a bag found.

    Attributes
    ----------
    config : PmrConfig
        The configuration diagnosed with (model, PMR settings, the diagnostician's window).
    config_origin : str
        ``bag`` or the ``--config`` file.
    outcomes : list of WindowOutcome
        Every update, in order, as the live diagnostician would publish it
        (and, see ``end_of_bag``, the window at the end of the data).
    recorded : list of RecordedVerdict
        The live diagnostician's verdicts on the bag's /diagnostics.
    comparisons : list of dict
        Per recorded verdict with a window: ``window``, ``equal`` and, if
        different, both sides.
    warnings : list of str
        The aligner's warnings (gaps, rejected messages).
    messages : dict
        Signal -> messages read.
    end_of_bag : bool
        The last outcome is an extra diagnosis of the window at the end of the
        data, which fell between two of the diagnostician's updates.
    """

    config: PmrConfig
    config_origin: str
    outcomes: list[WindowOutcome]
    recorded: list[RecordedVerdict]
    comparisons: list[dict[str, Any]] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    messages: dict[str, int] = field(default_factory=dict)
    end_of_bag: bool = False

    @property
    def final(self) -> WindowOutcome | None:
        """The last update (the whole run when the diagnostician diagnosed once)."""
        return self.outcomes[-1] if self.outcomes else None

    @property
    def final_diagnosis(self) -> Diagnosis:
        """The diagnosis of the last window (without numbers when it had no verdict)."""
        outcome = self.final
        if outcome is None:
            models = self.config.model.element_models()
            return Diagnosis.insufficient(
                method=self.config.pmr.method,
                models=models,
                reason="no diagnostician update in the bag's data",
                samples=0,
            )
        return outcome.diagnosis

    @property
    def all_equal(self) -> bool:
        """Whether every recorded window agrees with its offline diagnosis."""
        return all(c["equal"] for c in self.comparisons)


def bag_configuration(bag: Bag, config_path: str | None = None) -> tuple[PmrConfig, str]:
    """The model, PMR and window settings to diagnose ``bag`` with, and where they came from.

    The recorded configuration, unless ``config_path`` is given (a params file
    with at least the ``system`` block; the rest takes the declared defaults).

    Raises
    ------
    BagError
        The bag has no configuration and none was given.
    ConfigError
        The configuration is invalid.
    """
    if config_path is not None:
        return load_config(config_path), str(config_path)
    recorded = bag.run_config()
    if recorded is None:
        raise BagError(
            f"{bag.path}: the bag holds no run configuration; pass --config FILE with the controller's model"
        )
    return parse_config(recorded.params, f"{bag.path} (recorded configuration)"), "bag"


def _recorded_verdicts(bag: Bag, config: PmrConfig, namespace: str = "/") -> list[RecordedVerdict]:
    name = topic("diagnostics").resolved(namespace)
    if name not in bag.topics:
        return []
    out = []
    models = config.model.element_models()
    for message in bag.messages({name}):
        diagnosis, info = diagnosis_from_array(bag.decode(message), DIAGNOSTICIAN_NODE, models=models)
        if info.get("levels"):
            out.append(RecordedVerdict(diagnosis, info))
    return out


def required_topics(namespace: str = "/") -> dict[str, str]:
    """Topic name -> type the offline diagnosis needs (r, u, y of the node set in ``namespace``)."""
    return {topic(key).resolved(namespace): topic(key).type for key in SIGNAL_TOPICS.values()}


def bag_namespace(bag: Bag) -> str:
    """The namespace of the node set a bag recorded (``/`` unless it was recorded under one).

    Raises
    ------
    BagError
        The bag holds the signals of several node sets (choose one with ``--namespace``).
    """
    found = namespaces_of("setpoint", bag.topics)
    if len(found) > 1:
        raise BagError(
            f"{bag.path}: the bag holds the signals of {len(found)} node sets ({', '.join(found)}); "
            "choose one with --namespace"
        )
    return found[0] if found else "/"


def _replay(
    bag: Bag, config: PmrConfig, namespace: str = "/"
) -> tuple[list[WindowOutcome], list[str], dict[str, int], bool]:
    """Feed the bag's r, u, y through the live diagnostician's aligner and schedule."""
    model, window = config.model, config.diagnostician
    labels = {s: f"{s} on {topic(SIGNAL_TOPICS[s]).resolved(namespace)}" for s in SIGNALS}
    names = {"r": model.output_names, "u": model.input_names, "y": model.output_names}
    aligner = SampleAligner(model.sample_time, names, labels, window.window_samples, window.max_lag_samples)
    by_topic = {topic(SIGNAL_TOPICS[s]).resolved(namespace): s for s in SIGNALS}
    outcomes: list[WindowOutcome] = []
    warnings: list[str] = []
    counts = dict.fromkeys(SIGNALS, 0)
    for message in bag.messages(set(by_topic)):
        signal = by_topic[message.topic]
        counts[signal] += 1
        stamp, channel_names, values = read_signal(bag.decode(message))
        offer = offer_signal(
            aligner,
            signal,
            stamp_s=stamp,
            names=channel_names,
            values=values,
            update_period_samples=window.update_period_samples,
        )
        warnings.extend(offer.result.warnings)
        if offer.newly_lagging:
            warnings.append(offer.newly_lagging)
            outcomes.append(evaluate_window(aligner, config))
        if offer.update_due:
            outcomes.append(evaluate_window(aligner, config))
    end_of_bag = False
    if aligner.stretch_last is not None and (
        not outcomes or outcomes[-1].window.get("last_sample") != aligner.stretch_last
    ):
        # The data end between two updates (a killed recording, a short bag): diagnose what there is, too.
        outcomes.append(evaluate_window(aligner, config))
        end_of_bag = True
    return outcomes, warnings, counts, end_of_bag


def diagnose_bag(
    bag: Bag, config_path: str | None = None, method: str | None = None, *, namespace: str | None = None
) -> OfflineResult:
    """Diagnose a bag offline as the live diagnostician did, and compare with its recorded verdicts.

    ``method`` (``classic`` or ``parametric``) overrides the configuration's
    ``pmr.method``; recorded verdicts made with another method are not compared.
    ``namespace`` picks the node set whose topics are read (default: the one
    the bag recorded, see :func:`bag_namespace`).

    Raises
    ------
    BagError
        A needed topic is missing, empty or of the wrong type, or no configuration.
    """
    namespace = bag_namespace(bag) if namespace is None else namespace
    bag.require(required_topics(namespace))
    config, origin = bag_configuration(bag, config_path)
    if method is not None:
        config = replace(config, pmr=replace(config.pmr, method=method))
    outcomes, warnings, counts, end_of_bag = _replay(bag, config, namespace)
    result = OfflineResult(
        config,
        origin,
        outcomes,
        _recorded_verdicts(bag, config, namespace),
        warnings=warnings,
        messages=counts,
        end_of_bag=end_of_bag,
    )
    result.comparisons = compare(result.outcomes, result.recorded, config.pmr.method)
    others = sorted({v.diagnosis.method for v in result.recorded if v.diagnosis.status == "ok"} - {config.pmr.method})
    if others:
        result.warnings.insert(
            0,
            f"verdicts recorded with the {', '.join(others)} method are not compared with these ({config.pmr.method})",
        )
    return result


def compare(
    outcomes: list[WindowOutcome], recorded: list[RecordedVerdict], method: str | None = None
) -> list[dict[str, Any]]:
    """For every recorded verdict with a window, whether the offline one for that window agrees.

    With ``method``, recorded verdicts made with another method are left out.
    Agreeing means the same kind (verdict or none) and, for a verdict,
    :func:`~pmr_ros.core.results.compare_diagnoses` finds no difference:
    verdicts, flags, delays and strings equal, floats within its tolerance
    (the same data diagnosed on another machine differ in the last digits).
    """
    offline = {}
    for outcome in outcomes:
        if "first_sample" in outcome.window:
            offline[(outcome.window["first_sample"], outcome.window["last_sample"])] = outcome
    out = []
    for verdict in recorded:
        window = verdict.window
        if window is None or (
            method is not None and verdict.diagnosis.status == "ok" and verdict.diagnosis.method != method
        ):
            continue
        mine = offline.get(window)
        entry: dict[str, Any] = {
            "first_sample": window[0],
            "last_sample": window[1],
            "recorded_status": verdict.diagnosis.status,
        }
        if mine is None:
            entry.update(equal=False, offline_status="not diagnosed offline")
        else:
            mine_ok = mine.kind == VERDICT
            entry["offline_status"] = "ok" if mine_ok else mine.kind
            if verdict.diagnosis.status == "ok" and mine_ok:
                entry["differences"] = compare_diagnoses(
                    verdict.diagnosis.to_dict()["elements"], mine.diagnosis.to_dict()["elements"]
                )
                entry["equal"] = not entry["differences"]
            else:
                entry["equal"] = verdict.diagnosis.status != "ok" and not mine_ok
        out.append(entry)
    return out
