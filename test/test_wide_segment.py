"""The parametric method's automatic Welch segment holds enough bins for a wide row (issue 25, item 6).

A row of n columns needs 2 n + 2 fitted bins; under the default excitation the informative band ends near
0.7 rad/sample, 57 bins of a 512-sample segment.  Measured on a 32 x 32 half-empty unit at 65,536 samples:
0 of 512 modelled elements within specification with 512 samples a segment, 407 with 1024.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from pmr_ros.config import load_config
from pmr_ros.core.pmr.checks import (
    InsufficientData,
    check_stretches,
    segments_needed,
    unbroken_samples_needed,
    welch_segments,
)
from pmr_ros.core.pmr.parametric.settings import FIT_BAND
from pmr_ros.core.pmr.spectra import record_spectra
from pmr_ros.core.records import Record, moving_instruments
from pmr_ros.core.sim.model import TransferMatrix


def _unit(n: int) -> TransferMatrix:
    """An n x n unit of first-order elements with time constants of 6 samples (the slowest asks for 256)."""
    return TransferMatrix(np.ones((n, n)), np.full((n, n), 6.0), np.zeros((n, n)), 1.0)


@pytest.mark.parametrize(("inputs", "segment"), [(2, 512), (16, 512), (27, 512), (28, 1024), (32, 1024), (48, 1024)])
def test_the_segment_grows_with_the_columns_a_row_fits(inputs, segment):
    config = load_config(None)
    welch = config.parametric.welch(_unit(inputs), 65536, config.pmr)
    assert welch.segment_length == segment
    band_bins = math.floor(FIT_BAND / (2.0 * math.pi / welch.segment_length))
    assert band_bins >= 2 * inputs + 2  # the guard's least for a row of every input


def test_a_short_record_still_caps_the_segment():
    config = load_config(None)
    assert config.parametric.welch(_unit(32), 3000, config.pmr).segment_length == 512  # a quarter of the record


def _segments(welch, samples: int, settling: int) -> int:
    return welch.segments(samples - settling)


@pytest.mark.parametrize(("inputs", "samples"), [(8, 2400), (8, 3000), (8, 4096), (16, 6000), (16, 8192)])
def test_a_record_too_short_for_the_instruments_segments_is_read_with_the_longest_that_gives_them(inputs, samples):
    """2 n_z segments of the automatic length do not fit: the segment is the longest even one that gives them."""
    config = load_config(None)
    unit = _unit(inputs)
    need = segments_needed(inputs)
    automatic = config.parametric.welch(unit, samples, config.pmr)
    assert _segments(automatic, samples, unit.settling_samples()) < need
    welch = config.parametric.welch(unit, samples, config.pmr, instruments=inputs)
    assert welch.segment_length % 2 == 0 and welch.segment_length < automatic.segment_length
    assert _segments(welch, samples, unit.settling_samples()) >= need
    longer = replace(welch, segment_length=welch.segment_length + 2)
    assert _segments(longer, samples, unit.settling_samples()) < need
    assert math.floor(FIT_BAND / (2.0 * math.pi / welch.segment_length)) >= 2 * inputs + 2  # the guard's bins
    assert (welch.window, welch.overlap) == (automatic.window, automatic.overlap)


def test_the_segment_is_not_shortened_below_a_rows_bins_and_the_check_names_the_samples_needed():
    config = load_config(None)
    unit = _unit(16)
    welch = config.parametric.welch(unit, 4096, config.pmr, instruments=16)
    assert welch.segment_length == 306  # 2 pi (2 x 16 + 2) / 0.7 = 305.2, even
    needed = unbroken_samples_needed(unit, welch, instruments=16)
    assert needed == unit.settling_samples() + 306 + 31 * 153
    assert config.parametric.welch(unit, needed, config.pmr, instruments=16) == welch
    assert config.parametric.welch(unit, needed - 1, config.pmr, instruments=16) == welch


def test_enough_segments_a_set_segment_or_no_instruments_leave_the_segment_alone():
    config = load_config(None)
    unit = _unit(8)
    automatic = config.parametric.welch(unit, 65536, config.pmr)
    assert config.parametric.welch(unit, 65536, config.pmr, instruments=8) == automatic
    assert config.parametric.welch(unit, 4096, config.pmr, instruments=0) == config.parametric.welch(
        unit, 4096, config.pmr
    )
    fixed = replace(config.parametric, segment_length=1024)
    assert fixed.welch(unit, 4096, config.pmr, instruments=8).segment_length == 1024


def test_the_segment_counts_only_the_instruments_that_move_and_every_stretch():
    """Two stretches of 2,000 samples; 8 setpoints that move need 16 segments over both, a still one fewer."""
    config = load_config(None)
    unit = _unit(8)
    rng = np.random.default_rng(3)
    stretches = [
        Record(rng.standard_normal((2000, 8)), rng.standard_normal((2000, 8)), rng.standard_normal((2000, 8)))
        for _ in range(2)
    ]
    welch = config.parametric.welch_for(unit, stretches, config.pmr)
    assert welch == config.parametric.welch(unit, 2000, config.pmr, lengths=[2000, 2000], instruments=8)
    assert welch_segments([2000, 2000], model=unit, welch=welch) >= 16
    for s in stretches:
        s.r[:, 7] = 1.0  # one setpoint still: seven instruments, 14 segments, a longer segment
    still = config.parametric.welch_for(unit, stretches, config.pmr)
    assert still == config.parametric.welch(unit, 2000, config.pmr, lengths=[2000, 2000], instruments=7)
    assert still.segment_length > welch.segment_length


def test_the_instruments_at_hand_are_taken_not_computed_again():
    """welch_for, check_stretches and record_spectra take the caller's moving_instruments as they are."""
    config = load_config(None)
    unit = _unit(4)
    rng = np.random.default_rng(5)
    stretches = [Record(rng.standard_normal((3000, 4)), rng.standard_normal((3000, 4)), rng.standard_normal((3000, 4)))]
    moving = moving_instruments(stretches)
    welch = config.parametric.welch_for(unit, stretches, config.pmr, moving=moving)
    assert welch == config.parametric.welch_for(unit, stretches, config.pmr)
    check_stretches(stretches, model=unit, welch=welch, moving=moving)
    assert record_spectra(stretches, unit, welch, moving=moving).moving is moving
    # a set that says nothing moves is believed: the checks refuse what moves in fact
    still = replace(moving, setpoints=np.zeros(4, dtype=bool))
    assert still.count == 0
    with pytest.raises(InsufficientData, match="no excitation"):
        check_stretches(stretches, model=unit, welch=welch, moving=still)
