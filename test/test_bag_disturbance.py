"""Measured disturbances in bags: the contract topic, recorded like u, read back into ``Record.dv``.

A small bag with r, u, y and ``pmr/disturbance`` written through the
recorder's writer, replayed offline with a configuration that declares DVs:
every aligned stretch carries the DVs written, sample by sample; without the
topic (or without DVs in the configuration) the record has none, as before.
"""

from __future__ import annotations

import copy
from dataclasses import replace

import numpy as np
import pytest

from pmr_ros.bag.disturbances import config_disturbances, disturbance_topic
from pmr_ros.bag.offline import replay_bag
from pmr_ros.bag.reader import open_bag
from pmr_ros.bag.storage import recorded_topics, typestore
from pmr_ros.bag.writer import BagWriter
from pmr_ros.contract.topics import topic
from pmr_ros.contract.windowing import useful_data, window_stretches

SAMPLES = 120
DVS = ("feed_rate", "feed_comp")
CHANNELS = {
    "setpoint": ("x_D", "x_B"),
    "manipulated_input": ("reflux", "steam"),
    "measured_output": ("x_D", "x_B"),
    "disturbance": DVS,
}


def _joint_state(k: int, values: np.ndarray, names: tuple[str, ...]):
    ts = typestore().types
    stamp = ts["builtin_interfaces/msg/Time"](sec=k, nanosec=0)
    return ts["sensor_msgs/msg/JointState"](
        header=ts["std_msgs/msg/Header"](stamp=stamp, frame_id="wood_berry"),
        name=list(names),
        position=np.asarray(values, dtype=float),
        velocity=np.zeros(0),
        effort=np.zeros(0),
    )


def _write_routine_bag(path, record) -> None:
    """A bag of ``record``'s r, u, y and DVs (names of DV_MODEL), one message a sample and topic, 1 s apart."""
    from test_data_routine_diagnosis import DV_MODEL

    signals = {"setpoint": record.r, "manipulated_input": record.u, "measured_output": record.y}
    signals["disturbance"] = record.dv
    names = {**CHANNELS, "disturbance": DV_MODEL.input_names}
    with BagWriter(path, topics={k: t for k, t in recorded_topics().items() if k in signals}) as writer:
        for k in range(record.y.shape[0]):
            for key, values in signals.items():
                writer.write_message(topic(key).resolved(), k * 10**9 + 1, _joint_state(k, values[k], names[key]))


def _bag(path, *, with_dv: bool = True, gap: int | None = None) -> dict[str, np.ndarray]:
    """Write ``SAMPLES`` samples of every signal (DVs as random steps); the values written, by contract key."""
    rng = np.random.default_rng(4)
    values = {key: rng.normal(size=(SAMPLES, len(names))) for key, names in CHANNELS.items()}
    values["disturbance"] = np.repeat(rng.normal(size=(SAMPLES // 20, 2)), 20, axis=0)
    keys = [k for k in CHANNELS if with_dv or k != "disturbance"]
    with BagWriter(path, topics={k: t for k, t in recorded_topics().items() if k in keys}) as writer:
        for k in range(SAMPLES):
            for key in keys:
                if key == "disturbance" and k == gap:
                    continue  # a lost DV message: the sample is incomplete
                message = _joint_state(k, values[key][k], CHANNELS[key])
                writer.write_message(topic(key).resolved(), k * 10**9 + 1, message)
    return values


@pytest.fixture
def config(wood_berry):
    """Wood-Berry with two DVs declared (laid into the tree as ``system.disturbance_names`` gives them)."""
    tree = copy.deepcopy(wood_berry.parameters)
    tree["system"]["disturbance_names"] = list(DVS)
    window = replace(wood_berry.diagnostician, window_samples=SAMPLES, update_period_samples=10**6)
    return replace(wood_berry, parameters=tree, diagnostician=window)


def test_the_disturbance_topic_is_in_the_contract_like_u_and_recorded():
    dv, u = topic("disturbance"), topic("manipulated_input")
    assert dv.name == "pmr/disturbance" and dv.type == u.type and dv.qos == u.qos
    assert "position" in dv.fields and "header.stamp" in dv.fields
    assert "disturbance" in recorded_topics() and recorded_topics("/column_a")["disturbance"].name == (
        "/column_a/pmr/disturbance"
    )


def test_a_bag_with_the_disturbance_topic_gives_record_dv(tmp_path, config):
    written = _bag(tmp_path / "bag")
    bag = open_bag(tmp_path / "bag")
    assert disturbance_topic(bag, config) == "/pmr/disturbance" and config_disturbances(config) == DVS
    replay = replay_bag(bag, config)
    (stretch,) = window_stretches(replay.aligner, SAMPLES)
    assert stretch.first == 0 and stretch.samples == SAMPLES
    np.testing.assert_allclose(stretch.record.dv, written["disturbance"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(stretch.record.u, written["manipulated_input"], rtol=0, atol=1e-12)
    assert replay.counts["dv"] == SAMPLES
    (cut,) = window_stretches(replay.aligner, SAMPLES, since=30)
    np.testing.assert_allclose(cut.record.dv, written["disturbance"][30:], rtol=0, atol=1e-12)
    data = useful_data(replay.aligner, config)
    assert all(np.shape(d.dv) == (d.samples, 2) for d in data.all_stretches)


def test_a_lost_dv_message_breaks_the_stretch_like_a_lost_u(tmp_path, config):
    written = _bag(tmp_path / "bag", gap=70)
    replay = replay_bag(open_bag(tmp_path / "bag"), config)
    first, second = window_stretches(replay.aligner, SAMPLES)
    assert (first.first, first.samples, second.first) == (0, 70, 71)
    np.testing.assert_allclose(second.record.dv, written["disturbance"][71:], atol=1e-12)


def test_without_the_topic_or_without_dvs_the_record_has_none(tmp_path, config, wood_berry):
    _bag(tmp_path / "plain", with_dv=False)
    plain = open_bag(tmp_path / "plain")
    assert disturbance_topic(plain, config) is None
    (stretch,) = window_stretches(replay_bag(plain, config).aligner, SAMPLES)
    assert stretch.record.dv is None and stretch.samples == SAMPLES
    _bag(tmp_path / "full")
    full = open_bag(tmp_path / "full")
    assert disturbance_topic(full, wood_berry) is None  # no DVs declared: the topic is not read
    (stretch,) = window_stretches(replay_bag(full, wood_berry).aligner, SAMPLES)
    assert stretch.record.dv is None


def test_the_aligner_needs_the_dvs_it_was_given_and_names_them_when_they_stop():
    from pmr_ros.contract.alignment import SampleAligner

    names = {"r": ("a",), "u": ("p",), "y": ("a",), "dv": ("f",)}
    labels = {s: f"{s} on /pmr/{s}" for s in names}
    aligner = SampleAligner(1.0, names, labels, capacity=100, max_lag_samples=5)
    for k in range(20):
        for s in ("r", "u", "y") if k >= 10 else names:
            aligner.add(s, float(k), names[s], [float(k)])
    (stretch,) = aligner.stretches(100)
    assert stretch.samples == 10 and stretch.record.dv.tolist() == [[float(k)] for k in range(10)]
    assert aligner.lagging() == "dv on /pmr/dv stopped at sample 9 while the other signals reached sample 19"


def test_a_routine_runs_bag_is_diagnosed_with_its_d_elements_as_the_record(tmp_path, wood_berry):
    """The offline replay of a bag with DVs gives the record's verdicts, D elements included (with the D diagnosis)."""
    import routine_loop
    from test_data_routine_diagnosis import DV_MODEL, DV_PLANT

    from pmr_ros.contract.windowing import evaluate_window
    from pmr_ros.core.pmr.diagnosis import diagnose_stretches

    samples = 8192
    window = replace(wood_berry.diagnostician, window_samples=samples, update_period_samples=10**6)
    config = replace(wood_berry, disturbance_model=DV_MODEL, diagnostician=window)
    routine = routine_loop.Routine(dither=np.zeros(2), dv_amplitude=0.3, setpoint_steps=1.0)
    record = routine_loop.routine_run(config, config.model, routine, samples=samples, seed=2, disturbances=DV_PLANT)
    _write_routine_bag(tmp_path / "bag", record)
    outcome = evaluate_window(replay_bag(open_bag(tmp_path / "bag"), config).aligner, config)
    direct = diagnose_stretches(
        [replace(record, dither=None)],
        model=config.model,
        pmr=config.pmr,
        parametric=config.parametric,
        quality=config.quality,
        disturbance_model=DV_MODEL,
    )
    got = outcome.diagnosis
    assert got.status == direct.status == "ok", got.reason
    assert [e.name for e in got] == [e.name for e in direct] and "D11" in got.elements
    for name, theirs in direct.elements.items():
        assert got.elements[name].verdict == theirs.verdict, name
        ours, q = got.elements[name].parametric, theirs.parametric
        if q is not None and q.gain_mismatch_pct is not None:
            np.testing.assert_allclose(ours.gain_mismatch_pct, q.gain_mismatch_pct, rtol=1e-9, atol=1e-9, err_msg=name)
    d11 = got.elements["D11"].parametric  # the plant's D11 gain is 20 % above the model's
    assert d11.verdict == "mismatch" and abs(d11.gain_mismatch_pct - 20.0) <= 3.0
    assert all(got.elements[name].verdict == "ok" for name in ("G11", "G12", "G21", "G22", "D12", "D21"))


def test_rolling_windows_of_a_bag_carry_its_dvs_as_the_whole_bag_does(tmp_path):
    """``diagnose BAG --window``: the bag read once (:func:`bag_record`) has the DVs; each window its D elements."""
    import routine_loop
    import yaml
    from test_data_routine_diagnosis import DV_MODEL, DV_PLANT

    from pmr_ros.config import config_dir, load_config
    from pmr_ros.core.pmr.diagnosis import diagnose_stretches
    from pmr_ros.service.bag_diagnosis import bag_record
    from pmr_ros.service.monitoring import monitor

    tree = yaml.safe_load((config_dir() / "wood_berry.yaml").read_text())
    system = tree["/**"]["ros__parameters"]["system"]
    system.update(
        disturbance_names=list(DV_MODEL.input_names),
        disturbance_gain=DV_MODEL.gain.ravel().tolist(),
        disturbance_time_constant=np.nan_to_num(DV_MODEL.time_constant, nan=1.0).ravel().tolist(),
        disturbance_delay=DV_MODEL.delay.ravel().tolist(),
        disturbance_element_type=DV_MODEL.element_type.ravel().tolist(),
    )
    path = tmp_path / "with_dvs.yaml"
    path.write_text(yaml.safe_dump(tree))
    config = load_config(path)
    assert config.disturbance_model is not None and config.disturbance_model.n_inputs == 2
    samples = 8192
    routine = routine_loop.Routine(dither=np.zeros(2), dv_amplitude=0.3, setpoint_steps=1.0)
    record = routine_loop.routine_run(config, config.model, routine, samples=samples, seed=2, disturbances=DV_PLANT)
    _write_routine_bag(tmp_path / "bag", record)
    data, judged = bag_record(open_bag(tmp_path / "bag"), str(path))
    np.testing.assert_allclose(data.signals["dv"], record.dv, rtol=0, atol=1e-12)
    assert data.usable.all()
    found = monitor(data, judged, window=samples, step=samples, jobs=1)
    (only,) = found.windows
    direct = diagnose_stretches(
        data.stretches(), model=config.model, pmr=config.pmr, parametric=config.parametric, disturbance_model=DV_MODEL
    )
    assert list(only["elements"]) == list(direct.elements) and "D11" in only["elements"]
    for name, theirs in direct.elements.items():
        assert only["elements"][name]["verdict"] == theirs.verdict, name
    d11 = only["elements"]["D11"]["parametric"]  # the plant's D11 gain is 20 % above the model's
    assert d11["verdict"] == "mismatch" and abs(d11["gain_mismatch_pct"] - 20.0) <= 3.0
