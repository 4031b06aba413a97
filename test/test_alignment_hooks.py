"""The SampleAligner's hooks for the live diagnostician: snapshot, value, restart (pmr_ros.contract.alignment)."""

from __future__ import annotations

import numpy as np

from pmr_ros.config import load_config
from pmr_ros.contract.alignment import SampleAligner
from pmr_ros.contract.windowing import evaluate_window

NAMES = {"r": ("x_D", "x_B"), "u": ("reflux", "steam"), "y": ("x_D", "x_B")}
LABELS = {"r": "r on /pmr/setpoint", "u": "u on /pmr/manipulated_input", "y": "y on /pmr/measured_output"}


def _feed(al: SampleAligner, k: int, offset: float = 0.0) -> None:
    for s in ("r", "u", "y"):
        al.add(s, float(k), NAMES[s], [k + offset, -k - offset])


def test_a_snapshot_does_not_change_when_messages_keep_coming():
    al = SampleAligner(1.0, NAMES, LABELS, 5, 3)
    for k in range(4):
        _feed(al, k)
    al.add("y", 4.0, NAMES["y"], [4.0, -4.0])
    frozen = al.snapshot()
    for k in range(4, 9):
        _feed(al, k)
    r, u, y, first = frozen.window(10)
    assert first == 0 and frozen.stretch_last == 3 and frozen.stretch_length == 4
    assert np.array_equal(y[:, 0], [0, 1, 2, 3]) and frozen.newest == {"r": 3, "u": 3, "y": 4}
    assert al.window(10)[3] == 4 and al.stretch_last == 8  # the original went on


def test_a_snapshot_is_diagnosed_as_the_aligner_would_have_been():
    config = load_config(overrides={"run": {"samples": 600}, "pmr": {"segment_length": 128}})
    from pmr_ros.core.sim.closed_loop import simulate

    rec = simulate(config)
    settings = {"window_samples": 600, "min_samples": 500}
    config = load_config(overrides={"pmr": {"segment_length": 128}, "diagnostician": settings})
    al = SampleAligner(1.0, NAMES, LABELS, 600, 16)
    for k in range(600):
        for s, values in (("r", rec.r[k]), ("u", rec.u[k]), ("y", rec.y[k])):
            al.add(s, float(k), NAMES[s], values)
    frozen = al.snapshot()
    al.restart()
    now, then = evaluate_window(frozen, config), evaluate_window(al, config)
    assert then.kind == "insufficient_data" and now.kind == "verdict"
    assert now.diagnosis.elements == evaluate_window(frozen.snapshot(), config).diagnosis.elements


def test_value_gives_what_was_taken_for_a_sample_while_it_is_held():
    al = SampleAligner(1.0, NAMES, LABELS, 3, 3)
    for k in range(5):
        _feed(al, k)
    al.add("y", 5.0, NAMES["y"], [5.5, -5.5])  # waiting for r and u
    assert np.array_equal(al.value("y", 5), [5.5, -5.5]) and al.value("r", 5) is None
    assert np.array_equal(al.value("u", 4), [4.0, -4.0]) and np.array_equal(al.value("r", 2), [2.0, -2.0])
    assert al.value("r", 1) is None  # left the window (capacity 3)
    assert al.value("r", 9) is None


def test_restart_begins_a_new_stretch_like_a_gap():
    al = SampleAligner(1.0, NAMES, LABELS, 10, 3)
    for k in range(4):
        _feed(al, k)
    al.restart()
    assert al.stretch_length == 0 and al.gaps == 1 and al.newest == {"r": 3, "u": 3, "y": 3}
    _feed(al, 4)
    _feed(al, 5)
    assert al.stretch_first == 4 and al.stretch_length == 2 and al.window(10)[3] == 4
    fresh = SampleAligner(1.0, NAMES, LABELS, 10, 3)
    fresh.restart()
    assert fresh.gaps == 0
