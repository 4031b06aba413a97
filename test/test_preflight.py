"""A run that cannot succeed is refused in one line, with the figure, before anything is allocated or simulated."""

from __future__ import annotations

import time

import numpy as np
import pytest
import yaml

from pmr_ros import cli
from pmr_ros.config import config_dir, load_config
from pmr_ros.core.sim.footprint import model_bytes, realization_bytes, samples_needed, states


def _square(tmp_path, n: int, *, delay: float = 1.0) -> str:
    """An n x n model: gain 1 on the diagonal, 0.2 elsewhere, tau 10, delay 1 (the first element ``delay``)."""
    gain = np.full((n, n), 0.2)
    np.fill_diagonal(gain, 1.0)
    delays = np.full(n * n, 1.0)
    delays[0] = delay
    params = {
        "system": {
            "name": f"square{n}",
            "sample_time": 1.0,
            "output_names": [f"y{i + 1}" for i in range(n)],
            "input_names": [f"u{i + 1}" for i in range(n)],
            "gain": gain.ravel().tolist(),
            "time_constant": [10.0] * (n * n),
            "delay": delays.tolist(),
        },
        "prbs": {"register_length": 16},
    }
    path = tmp_path / f"square{n}.yaml"
    # libyaml's dumper when there is one: the same text as yaml.safe_dump, in a third of the time (40,000 numbers)
    dumper = getattr(yaml, "CSafeDumper", yaml.SafeDumper)
    path.write_text(yaml.dump({"/**": {"ros__parameters": params}}, Dumper=dumper))
    return str(path)


def _refused(capsys, argv: list[str], *words: str) -> str:
    start = time.monotonic()
    code = cli.main(argv)
    elapsed = time.monotonic() - start
    err = capsys.readouterr().err.strip()
    assert code != 0 and err.count("\n") == 0, err
    assert "Traceback" not in err
    for word in words:
        assert word in err, err
    assert elapsed < 20.0, elapsed  # refused before building or simulating
    return err


def test_states_count_elements_and_delay_registers(wood_berry):
    assert states(wood_berry.model) == 4 + 7 + 3
    assert realization_bytes(wood_berry.model) == 8 * 3 * 14 * (14 + 2 + 2)


def test_a_200_by_200_model_is_refused_with_its_states_and_memory(tmp_path, capsys, monkeypatch):
    path = _square(tmp_path, 200)
    config = load_config(path)
    needed = model_bytes(config.model, config.plant(), prediction_horizon=40, control_horizon=8)
    # the same on every machine: one with half of what the model needs (a 24 GB machine has less still)
    monkeypatch.setattr("pmr_ros.core.sim.memory.available_bytes", lambda: needed // 2)
    _refused(capsys, ["run", "--batch", "--config", path], "200x200 model has 40200 states", "GB")


def test_a_plant_delay_of_a_million_samples_is_refused_naming_the_plants_states(capsys, tmp_path):
    text = (
        (config_dir() / "wood_berry.yaml")
        .read_text()
        .replace("delay_samples: [0, 1, 2, 0]", "delay_samples: [1000000, 1, 2, 0]")
    )
    path = tmp_path / "far_delay.yaml"
    path.write_text(text)
    _refused(
        capsys,
        ["run", "--batch", "--config", str(path), "--scenario", "delay"],
        "the 2x2 model has 14 states, the plant 1000009",
        "TB of memory",
    )


def test_a_64_by_64_model_with_too_few_samples_is_insufficient_before_simulating(tmp_path, capsys):
    path = _square(tmp_path, 64)
    config = load_config(path)
    welch = config.parametric.welch(config.model, 16384, config.pmr, instruments=64)
    needed = samples_needed(config.model, welch)
    # 128 segments do not fit in 16,384 samples at any length; the shortest segment a row of 64 columns
    # allows has 2 * 64 + 2 bins below 0.7 rad/sample: 1,168 samples (parametric/settings.py)
    assert welch.segment_length == 1168
    assert needed == 82 + 1168 + 127 * 584
    start = time.monotonic()
    assert cli.main(["run", "--batch", "--config", path]) == 3
    assert time.monotonic() - start < 20.0  # the 74 s simulation is not run
    out = capsys.readouterr().out.splitlines()
    assert out[1].startswith("INSUFFICIENT DATA: window too short, known before simulating: 16384 samples for a 64x64")
    assert f"needs at least {needed} (82 of settling, then 128 Welch segments of 1168" in out[1]
    assert f"--samples {needed}" in out[1]


def test_the_samples_needed_before_simulating_are_the_checks_own_rule(wood_berry):
    """One rule: check_stretches refuses one sample fewer than unbroken_samples_needed and accepts that many."""
    from pmr_ros.core.pmr.checks import (
        InsufficientData,
        check_stretches,
        segments_needed,
        unbroken_samples_needed,
        welch_segments,
    )
    from pmr_ros.core.pmr.diagnosis import method_welch
    from pmr_ros.core.records import Record

    model = wood_berry.model
    welch = method_welch(4000, model=model, pmr=wood_berry.pmr, parametric=wood_berry.parametric)
    assert welch == wood_berry.parametric.welch(model, 4000, wood_berry.pmr)
    assert method_welch(4000, model=model, pmr=wood_berry.pmr, parametric=wood_berry.parametric, method="classic") == (
        wood_berry.pmr.welch
    )
    need = unbroken_samples_needed(model, welch, instruments=2)
    assert need == samples_needed(model, welch) == model.settling_samples() + 512 + 3 * 256
    assert segments_needed(2) == 4 and segments_needed(5) == 10
    assert welch_segments([need, need - 1], model=model, welch=welch) == 4 + 3
    rng = np.random.default_rng(0)

    def record(n: int) -> Record:
        return Record(rng.standard_normal((n, 2)), rng.standard_normal((n, 2)), rng.standard_normal((n, 2)))

    check_stretches([record(need)], model=model, welch=welch)
    with pytest.raises(InsufficientData, match=f"give 3 Welch segments of 512, need 4 \\({need} unbroken samples\\)"):
        check_stretches([record(need - 1)], model=model, welch=welch)


def test_the_samples_needed_count_what_moves_not_every_setpoint():
    """A zone CV, a DV that stands still, dither and manual stretches: the instruments the run's record will have."""
    from pmr_ros.core.records import moving_instruments
    from pmr_ros.core.sim.augment import augmented_record
    from pmr_ros.core.sim.closed_loop import simulate
    from pmr_ros.core.sim.footprint import planned_instruments

    config = load_config(
        overrides={
            "system": {
                "disturbance_names": ["feed", "feed_comp"],
                "disturbance_gain": [3.0, 2.0, 1.5, 1.0],
                "disturbance_time_constant": [12.0, 8.0, 9.0, 6.0],
                "disturbance_delay": [2.0, 1.0, 3.0, 2.0],
            },
            "disturbance_signal": {"amplitude": [0.1, 0.0]},
            "mpc": {"output_mode": ["setpoint", "zone"], "output_low": [-np.inf, -1.0], "output_high": [np.inf, 1.0]},
            "excitation": {"mv_dither_amplitude": [0.2, 0.0]},
            "run": {"manual_stretches": [[300, 400, 1], [900, 300, 1]]},
        }
    )
    # x_D's setpoint, reflux's dither, feed (feed_comp stands still), steam in manual; x_B is a zone CV
    assert planned_instruments(config) == 4
    record = simulate(config, samples=1500, seed=3)
    moving = moving_instruments([augmented_record(record, 2)])
    assert moving.count == planned_instruments(config)
    welch = config.parametric.welch(config.model, 16384, config.pmr)
    settling, segment = config.model.settling_samples(), welch.segment_length
    assert samples_needed(config.model, welch, instruments=4) == settling + segment + 7 * welch.step
    # the default still counts every setpoint and the dithered inputs
    assert samples_needed(config.model, welch, dithered_inputs=1) == settling + segment + 5 * welch.step
    assert planned_instruments(load_config()) == 2
