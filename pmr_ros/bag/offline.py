"""Offline diagnosis of a bag: the live diagnostician's alignment and windows, without ROS.

The recorded r, u and y messages go, in recording order, through the same
:class:`~pmr_ros.ros.alignment.SampleAligner` and the same update schedule and
window evaluation (:mod:`pmr_ros.ros.windowing`) as in the live
``pmr_diagnostician``, with the model, PMR settings and diagnostician window
of the recorded configuration (or of ``--config``).  Every window the live
node diagnosed is diagnosed again, and the verdicts recorded on /diagnostics
are compared with the offline ones number for number.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from ..core.config import ConfigError, PmrConfig, load_config, parse_config
from ..core.pmr import Diagnosis, ElementDiagnosis
from ..ros.alignment import SIGNALS, SampleAligner
from ..ros.contract import topic
from ..ros.layout import diagnosis_from_array, read_signal
from ..ros.parameters import NodeSettings, parse_node_settings
from ..ros.windowing import VERDICT, WindowOutcome, evaluate_window, offer_signal
from .reader import Bag
from .schema import SIGNAL_KEYS, BagError

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
    info: dict

    @property
    def window(self) -> tuple[int, int] | None:
        if "first_sample" not in self.info:
            return None
        return int(self.info["first_sample"]), int(self.info["last_sample"])


@dataclass
class OfflineResult:
    """Everything the offline diagnosis of a bag found.

    Attributes
    ----------
    config : PmrConfig
        The configuration diagnosed with (model, PMR settings).
    settings : NodeSettings
        The diagnostician's window settings used.
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
    settings: NodeSettings
    config_origin: str
    outcomes: list[WindowOutcome]
    recorded: list[RecordedVerdict]
    comparisons: list[dict] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    messages: dict[str, int] = field(default_factory=dict)
    end_of_bag: bool = False

    @property
    def final(self) -> WindowOutcome | None:
        """The last update (the whole run when the diagnostician diagnosed once)."""
        return self.outcomes[-1] if self.outcomes else None

    @property
    def final_diagnosis(self) -> Diagnosis:
        outcome = self.final
        if outcome is None:
            names = self.config.model.element_names()
            return Diagnosis({n: ElementDiagnosis(n) for n in names}, "insufficient_data", "no diagnostician update in the bag's data", 0)
        if outcome.kind == VERDICT:
            return outcome.diagnosis
        names = self.config.model.element_names()
        return Diagnosis({n: ElementDiagnosis(n) for n in names}, "insufficient_data", outcome.reason, int(outcome.window.get("window_samples", 0)))

    @property
    def all_equal(self) -> bool:
        return all(c["equal"] for c in self.comparisons)


def bag_configuration(bag: Bag, config_path: str | None = None) -> tuple[PmrConfig, NodeSettings, str]:
    """The model, PMR and window settings to diagnose ``bag`` with.

    The recorded configuration, unless ``config_path`` is given; a params file
    there is laid over the shipped defaults like any ``--config``.

    Raises
    ------
    BagError
        The bag has no configuration and none was given.
    ConfigError
        The configuration is invalid.
    """
    if config_path is not None:
        config = load_config(config_path)
        tree = config.parameters
        origin = str(config_path)
    else:
        recorded = bag.run_config()
        if recorded is None:
            raise BagError(f"{bag.path}: the bag holds no run configuration; pass --config FILE with the controller's model")
        tree = recorded.params
        origin = "bag"
        config = parse_config(tree, f"{bag.path} (recorded configuration)")
    try:
        settings = parse_node_settings(tree, origin)
    except ConfigError:
        # A plain system file without the node-set block: the shipped diagnostician defaults.
        settings = parse_node_settings(load_config().parameters, origin)
    return config, settings, origin


def _recorded_verdicts(bag: Bag) -> list[RecordedVerdict]:
    name = topic("diagnostics").name
    if name not in bag.topics:
        return []
    out = []
    for message in bag.messages({name}):
        diagnosis, info = diagnosis_from_array(bag.decode(message), DIAGNOSTICIAN_NODE)
        if info.get("levels"):
            out.append(RecordedVerdict(diagnosis, info))
    return out


def required_topics() -> dict[str, str]:
    """Topic name -> type the offline diagnosis needs (r, u, y)."""
    return {topic(key).name: topic(key).type for key in SIGNAL_KEYS.values()}


def diagnose_bag(bag: Bag, config_path: str | None = None, method: str | None = None) -> OfflineResult:
    """Diagnose a bag offline as the live diagnostician did, and compare with its recorded verdicts.

    ``method`` (``classic`` or ``parametric``) overrides the configuration's
    ``pmr.method``; recorded verdicts made with another method are not compared.

    Raises
    ------
    BagError
        A needed topic is missing, empty or of the wrong type, or no configuration.
    """
    bag.require(required_topics())
    config, settings, origin = bag_configuration(bag, config_path)
    if method is not None:
        config = replace(config, pmr=replace(config.pmr, method=method))
    model = config.model
    labels = {s: f"{s} on {topic(SIGNAL_KEYS[s]).name}" for s in SIGNALS}
    names = {"r": model.output_names, "u": model.input_names, "y": model.output_names}
    aligner = SampleAligner(model.sample_time, names, labels, settings.window_samples, settings.max_lag_samples)
    by_topic = {topic(SIGNAL_KEYS[s]).name: s for s in SIGNALS}
    outcomes: list[WindowOutcome] = []
    warnings: list[str] = []
    counts = dict.fromkeys(SIGNALS, 0)
    for message in bag.messages(set(by_topic)):
        signal = by_topic[message.topic]
        counts[signal] += 1
        stamp, channel_names, values = read_signal(bag.decode(message))
        offer = offer_signal(aligner, signal, stamp, channel_names, values, settings.update_period_samples)
        warnings.extend(offer.result.warnings)
        if offer.newly_lagging:
            warnings.append(offer.newly_lagging)
            outcomes.append(evaluate_window(aligner, config, settings.window_samples, settings.min_samples))
        if offer.update_due:
            outcomes.append(evaluate_window(aligner, config, settings.window_samples, settings.min_samples))
    end_of_bag = False
    if aligner.stretch_last is not None and (not outcomes or outcomes[-1].window.get("last_sample") != aligner.stretch_last):
        # The data end between two updates (a killed recording, a short bag): diagnose what there is, too.
        outcomes.append(evaluate_window(aligner, config, settings.window_samples, settings.min_samples))
        end_of_bag = True
    result = OfflineResult(config, settings, origin, outcomes, _recorded_verdicts(bag), warnings=warnings, messages=counts, end_of_bag=end_of_bag)
    result.comparisons = compare(result.outcomes, result.recorded, config.pmr.method)
    others = sorted({v.diagnosis.method for v in result.recorded if v.diagnosis.status == "ok"} - {config.pmr.method})
    if others:
        result.warnings.insert(0, f"verdicts recorded with the {', '.join(others)} method are not compared with these ({config.pmr.method})")
    return result


def verdict_numbers(diagnosis: Diagnosis | None) -> dict:
    """Element -> every field of its report entry (empty for None).

    /diagnostics carries all of them losslessly (``repr`` floats, the parametric
    intervals, verdicts, reasons and quality included), so all are compared.
    """
    if diagnosis is None:
        return {}
    return {name: element.to_dict() for name, element in diagnosis.elements.items()}


def compare(outcomes: list[WindowOutcome], recorded: list[RecordedVerdict], method: str | None = None) -> list[dict]:
    """For every recorded verdict with a window, whether the offline one for that window is equal.

    With ``method``, recorded verdicts made with another method are left out.

    Equal means the same kind (verdict or none) and, for a verdict, the same
    numbers and flags exactly (KeyValues are lossless ``repr`` floats).
    """
    offline = {}
    for outcome in outcomes:
        if "first_sample" in outcome.window:
            offline[(outcome.window["first_sample"], outcome.window["last_sample"])] = outcome
    out = []
    for verdict in recorded:
        window = verdict.window
        if window is None or (method is not None and verdict.diagnosis.status == "ok" and verdict.diagnosis.method != method):
            continue
        mine = offline.get(window)
        entry = {"first_sample": window[0], "last_sample": window[1], "recorded_status": verdict.diagnosis.status}
        if mine is None:
            entry.update(equal=False, offline_status="not diagnosed offline")
        else:
            mine_ok = mine.kind == VERDICT
            entry["offline_status"] = "ok" if mine_ok else mine.kind
            if verdict.diagnosis.status == "ok" and mine_ok:
                entry["equal"] = verdict_numbers(verdict.diagnosis) == verdict_numbers(mine.diagnosis)
            else:
                entry["equal"] = verdict.diagnosis.status != "ok" and not mine_ok
            if not entry["equal"]:
                entry.update(recorded=verdict_numbers(verdict.diagnosis), offline=verdict_numbers(mine.diagnosis))
        out.append(entry)
    return out

