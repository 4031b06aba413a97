"""Offline diagnosis of a bag: the live diagnostician's alignment and windows, without ROS.

The recorded r, u and y messages (and the measured disturbances of
``pmr/disturbance``, when the configuration declares DVs and the bag holds
them: :attr:`Record.dv`) go, in recording order, through the same
:class:`~pmr_ros.contract.alignment.SampleAligner` and the same update schedule and
window evaluation (:mod:`pmr_ros.contract.windowing`) as in the live
``pmr_diagnostician``, with the model, PMR settings and diagnostician window
of the recorded configuration (or of ``--config``).  Every window the live
node diagnosed is diagnosed again (:func:`replay_bag`);
:mod:`pmr_ros.service.bag_diagnosis` compares the verdicts recorded on
/diagnostics with the offline ones number for number.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field, replace
from typing import Any

from ..config import ConfigError, PmrConfig, load_config, parse_config
from ..config.write import configured_system_tree
from ..contract.alignment import MANUAL, SIGNALS, SampleAligner
from ..contract.layout import diagnosis_from_array, read_signal
from ..contract.model_topics import read_active_model, with_system
from ..contract.samples import AddResult
from ..contract.topics import SIGNAL_TOPICS, namespaces_of, topic
from ..contract.windowing import WindowOutcome, evaluate_window, offer_signal
from ..core.results import Diagnosis
from .disturbances import DISTURBANCE_KEY, config_disturbances, disturbance_topic
from .reader import Bag
from .storage import BagError

__all__ = [
    "DropCounts",
    "OfflineResult",
    "RecordedVerdict",
    "bag_configuration",
    "bag_namespace",
    "check_system",
    "held_samples",
    "recorded_verdicts",
    "replay_bag",
    "required_topics",
]

EXAMPLES = 3
"""Rejected messages quoted per signal on the console and in the report."""

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
class DropCounts:
    """The messages the aligner rejected, per signal and kind of problem, with the first few quoted.

    Attributes
    ----------
    counts : dict
        Signal label (``y on /pmr/measured_output``) -> kind (``non-finite value``,
        ``duplicated`` ...) -> messages.
    examples : dict
        Signal label -> the first :data:`EXAMPLES` rejection texts.
    """

    counts: dict[str, Counter] = field(default_factory=dict)
    examples: dict[str, list[str]] = field(default_factory=dict)

    def note(self, label: str, result: AddResult) -> None:
        """Count ``result`` if it rejected a message of ``label``."""
        if not result.rejected_as:
            return
        self.counts.setdefault(label, Counter())[result.rejected_as] += 1
        quoted = self.examples.setdefault(label, [])
        if len(quoted) < EXAMPLES:
            quoted.extend(result.warnings[:1])

    @property
    def total(self) -> int:
        """Messages rejected, all signals."""
        return sum(sum(c.values()) for c in self.counts.values())

    def lines(self) -> list[str]:
        """One line per signal with drops (``N dropped: a non-finite value, b duplicated``), then the examples."""
        out = []
        for label, counts in self.counts.items():
            kinds = ", ".join(f"{n} {kind}" for kind, n in counts.most_common())
            total = sum(counts.values())
            out.append(f"{label}: {total} message{'s' if total > 1 else ''} dropped ({kinds})")
            out += [f"  e.g. {text}" for text in self.examples.get(label, [])]
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: per signal, the counts by kind and the examples."""
        return {
            label: {"dropped": sum(c.values()), "by_kind": dict(c), "examples": self.examples.get(label, [])}
            for label, c in self.counts.items()
        }


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
    drops : DropCounts
        The rejected messages, counted per signal and kind.
    gaps : int
        Times the data broke into a new stretch.
    notes : list of str
        What the console should say about how the bag was judged.
    namespace : str
        The node set whose topics were read.
    """

    config: PmrConfig
    config_origin: str
    outcomes: list[WindowOutcome]
    recorded: list[RecordedVerdict]
    comparisons: list[dict[str, Any]] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    messages: dict[str, int] = field(default_factory=dict)
    end_of_bag: bool = False
    drops: DropCounts = field(default_factory=DropCounts)
    gaps: int = 0
    notes: list[str] = field(default_factory=list)
    namespace: str = "/"

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
            reason = "no complete sample of r, u and y in the bag"
            if self.drops.total:
                first = next(iter(self.drops.examples.values()))[0]
                reason += f": {self.drops.total} messages dropped, the first: {first}"
            return Diagnosis.insufficient(method=self.config.pmr.method, models=models, reason=reason, samples=0)
        return outcome.diagnosis

    @property
    def all_equal(self) -> bool:
        """Whether every recorded window agrees with its offline diagnosis."""
        return all(c["equal"] for c in self.comparisons)

    @property
    def not_diagnosed_live(self) -> int:
        """Recorded windows the live node gave no verdict for (stale or too few samples): nothing to compare."""
        return sum(1 for v in self.recorded if v.window is not None and v.diagnosis.status != "ok")


def bag_configuration(bag: Bag, config_path: str | None = None) -> tuple[PmrConfig, str]:
    """The model, PMR and window settings to diagnose ``bag`` with, and where they came from.

    The recorded configuration, unless ``config_path`` is given (a params file
    with at least the ``system`` block; the rest takes the declared defaults).
    A recorded configuration's step-response curves are the copies the bag
    holds (:mod:`.embedded_curves`), not the files its paths name.

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
    # the curve files as the run had them, from the bag: the recorded paths may not exist here
    curves = recorded.curve_sets()
    return parse_config(recorded.params, f"{bag.path} (recorded configuration)", curves=curves), "bag"


def recorded_verdicts(bag: Bag, config: PmrConfig, namespace: str = "/") -> list[RecordedVerdict]:
    """The live diagnostician's statuses on the bag's /diagnostics that carry verdict levels, decoded."""
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


def _signal_labels(namespace: str = "/") -> dict[str, str]:
    keys = {**SIGNAL_TOPICS, "dv": DISTURBANCE_KEY}
    return {s: f"{s} on {topic(key).resolved(namespace)}" for s, key in keys.items()}


def check_system(bag: Bag, config: PmrConfig, origin: str, namespace: str = "/") -> None:
    """Refuse a configuration whose channels are not those of the bag's signals.

    The first messages of r, u and y must carry as many values (and, when
    named, the same channel names) as the configuration has channels;
    otherwise every message would be dropped and the diagnosis would only
    say that there are no data.

    Raises
    ------
    BagError
        Naming the topic, the field and both widths.
    """
    model = config.model
    expected = {"r": model.output_names, "u": model.input_names, "y": model.output_names}
    for signal, key in SIGNAL_TOPICS.items():
        name = topic(key).resolved(namespace)
        seen = []
        for message in bag.messages({name}):
            seen.append(read_signal(bag.decode(message)))
            if len(seen) == 5:
                break
        widths = {len(values) for _, _, values in seen}
        names = {channels for _, channels, _ in seen}
        want = expected[signal]
        if len(widths) == 1 and widths != {len(want)}:
            shown = f" ({', '.join(next(iter(names)))})" if len(names) == 1 and next(iter(names)) else ""
            raise BagError(
                f"{bag.path}: {name} carries {widths.pop()} values{shown} in position where the configuration "
                f"({origin}) expects {len(want)} ({', '.join(want)}): the bag was recorded from another system"
            )
        if len(names) == 1 and next(iter(names)) and next(iter(names)) != tuple(want):
            raise BagError(
                f"{bag.path}: {name} names its channels {', '.join(next(iter(names)))} where the configuration "
                f"({origin}) has {', '.join(want)}: the bag was recorded from another system"
            )


class _Replay:
    """The bag's r, u, y through the live diagnostician's aligner and schedule."""

    def __init__(self, config: PmrConfig, namespace: str = "/", *, disturbances: bool = False) -> None:
        model, window = config.model, config.diagnostician
        names = {"r": model.output_names, "u": model.input_names, "y": model.output_names, MANUAL: model.input_names}
        if disturbances:
            names["dv"] = config_disturbances(config)
        self.labels = _signal_labels(namespace)
        self.config = config
        self.aligner = SampleAligner(
            model.sample_time, names, self.labels, window.window_samples, window.max_lag_samples
        )
        self.outcomes: list[WindowOutcome] = []
        self.warnings: list[str] = []
        self.counts = {s: 0 for s in self.aligner.signals if s != MANUAL}  # the modes come on u
        self.drops = DropCounts()
        self.model_since = 0
        """The first sample of the model the controller ran on last (after a recorded model switch)."""

    def offer(self, signal: str, message: Any) -> None:
        """One recorded message of ``signal`` (decoded)."""
        self.counts[signal] += 1
        stamp, channel_names, values = read_signal(message)
        offer = offer_signal(
            self.aligner,
            signal,
            stamp_s=stamp,
            names=channel_names,
            values=values,
            update_period_samples=self.config.diagnostician.update_period_samples,
            effort=getattr(message, "effort", ()),
        )
        self.warnings.extend(offer.result.warnings)
        self.drops.note(self.labels[signal], offer.result)
        if offer.newly_lagging:
            self.warnings.append(offer.newly_lagging)
            self.outcomes.append(evaluate_window(self.aligner, self.config, since=self.model_since))
        if offer.update_due:
            self.outcomes.append(evaluate_window(self.aligner, self.config, since=self.model_since))

    def follow(self, text: str, source: str) -> None:
        """A recorded ``pmr/active_model``: as the live diagnostician, diagnose against it from its first sample on."""
        try:
            active = read_active_model(text, source)
            if active.system == configured_system_tree(self.config.model, self.config.parameters):
                return
            # the model alone: the judged settings (method, --min-samples) stay as they are
            model = with_system(self.config, active.system, source).model
        except ConfigError as exc:
            self.warnings.append(f"ignored: {exc}")
            return
        self.config = replace(self.config, model=model)
        self.model_since = active.first_sample

    def finish(self) -> bool:
        """Diagnose the window at the end of the data if no update fell on it; whether one was added."""
        last = self.aligner.stretch_last
        if last is None or (self.outcomes and self.outcomes[-1].window.get("last_sample") == last):
            return False
        # The data end between two updates (a killed recording, a short bag): diagnose what there is, too.
        self.outcomes.append(evaluate_window(self.aligner, self.config, since=self.model_since))
        return True


def replay_bag(bag: Bag, config: PmrConfig, namespace: str = "/") -> _Replay:
    """Feed the r, u, y (and DVs) of the node set in ``namespace`` through the live diagnostician's aligner."""
    dv = disturbance_topic(bag, config, namespace)
    replay = _Replay(config, namespace, disturbances=dv is not None)
    by_topic = {topic(SIGNAL_TOPICS[s]).resolved(namespace): s for s in SIGNALS} | ({dv: "dv"} if dv else {})
    models = topic("active_model").resolved(namespace)
    for message in bag.messages({*by_topic, models}):
        if message.topic == models:
            replay.follow(bag.decode(message).data, f"{models} in {bag.path}")
        else:
            replay.offer(by_topic[message.topic], bag.decode(message))
    return replay


def held_samples(bag: Bag, namespace: str = "/") -> int:
    """Samples of r, u and y the bag holds (messages of the sparsest signal)."""
    return min(bag.counts.get(topic(SIGNAL_TOPICS[s]).resolved(namespace), 0) for s in SIGNALS)
