"""Rolling windows from pieces computed once (:mod:`pmr_ros.core.pmr.piecewise`): the same diagnosis as alone.

A window's spectra joined from its stretches' pieces are the very arrays of
the window computed alone (the same segments in the same order), so every
window's diagnosis is that of the window done alone to the last bit: verdicts
and numbers exactly (stated tolerance: none).
"""

from __future__ import annotations

import numpy as np
import pytest
from drifting import DAY, Change, drifting_data
from scipy.signal import lfilter_zi

from pmr_ros.config import load_config
from pmr_ros.core.pmr.parametric.ratio import _first_order_zi
from pmr_ros.core.pmr.parametric.verdicts import mixture_interval
from pmr_ros.core.pmr.piecewise import PieceCache, PiecewiseSpectra, stacked_segment_ffts
from pmr_ros.core.pmr.spectra import RecordSpectra, WelchSettings, record_spectra, segment_spectra
from pmr_ros.core.results.codec import diagnosis_to_json
from pmr_ros.core.sim.model import Mismatch
from pmr_ros.service.monitoring import WindowJob, diagnose_window, stretch_spans, window_stretches


@pytest.fixture(scope="module")
def job():
    """Five days of the Wood-Berry column's closed loop, G22's delay stepping +2 samples on day 2."""
    config = load_config(None)
    data = drifting_data(config, days=5, changes=(Change(1, 1, "delay", day=2, size=2),))
    return WindowJob(config, data, data.usable)


def _leaves(value, path=""):
    if isinstance(value, dict):
        for key, item in value.items():
            yield from _leaves(item, f"{path}.{key}")
    elif isinstance(value, list | tuple):
        for index, item in enumerate(value):
            yield from _leaves(item, f"{path}[{index}]")
    else:
        yield path, value


def _assert_same_diagnosis(alone, pieced):
    a, b = dict(_leaves(diagnosis_to_json(alone))), dict(_leaves(diagnosis_to_json(pieced)))
    assert a.keys() == b.keys()
    for path, value in a.items():
        if isinstance(value, float):
            np.testing.assert_array_equal(b[path], value, err_msg=path)  # NaN equals NaN here
        else:
            assert b[path] == value, path  # verdicts, reasons, status


def test_rolling_windows_from_pieces_are_the_windows_alone(job):
    pieces = PieceCache(job.config.model)
    spans = [(start * DAY, (start + 3) * DAY - 1) for start in range(3)]  # 3-day windows stepped by a day
    verdicts = set()
    for span in spans:
        alone = diagnose_window(job, span)
        pieced = diagnose_window(job, span, pieces=pieces)
        _assert_same_diagnosis(alone, pieced)
        verdicts |= {e.verdict for e in alone.elements.values()}
    assert "mismatch" in verdicts  # the windows decide something (the delay step), so there is a verdict to keep
    assert pieces.computed == 3 + 1 + 1  # each day's instruments transformed once: three, then one a window


def test_a_window_takes_the_stretches_it_shares_from_the_window_before(job):
    pieces = PieceCache(job.config.model)
    first = window_stretches(job, 0, 3 * DAY - 1, pieces=pieces)
    with pieces.window(first, stretch_spans(job, 0, 3 * DAY - 1)):
        pass
    second = window_stretches(job, DAY, 4 * DAY - 1, pieces=pieces)
    alone = window_stretches(job, DAY, 4 * DAY - 1)
    assert len(second) == len(alone) == 3 and second[0] is first[1] and second[1] is first[2]
    for kept, fresh in zip(second, alone, strict=True):
        for name in ("r", "u", "y"):
            np.testing.assert_array_equal(getattr(kept, name), getattr(fresh, name), err_msg=name)
            np.testing.assert_allclose(getattr(kept, name).mean(axis=0), 0.0, atol=1e-9)  # the deviations


def test_a_stretch_keeps_every_sample_of_its_modes(job):
    from dataclasses import replace

    manual = np.zeros((job.data.samples, job.config.model.n_inputs), dtype=bool)
    manual[DAY + 100 : DAY + 400, 1] = True  # the second MV in manual for 300 samples of day 1
    moded = replace(job, data=replace(job.data, manual=manual))
    stretches = window_stretches(moded, 0, 3 * DAY - 1)
    assert [s.manual is None for s in stretches] == [True, False, True]
    for stretch in stretches[1:2]:
        assert stretch.manual.shape == stretch.u.shape and int(stretch.manual.sum()) == 300


def test_piecewise_spectra_equal_the_record_spectra(job):
    stretches = window_stretches(job, 0, 3 * DAY - 1)
    model = job.config.model
    welch = WelchSettings(segment_length=256)
    alone = RecordSpectra(stretches, model, welch)
    pieces = PieceCache(model)
    with pieces.window(stretches, stretch_spans(job, 0, 3 * DAY - 1)):
        pieced = record_spectra(stretches, model, welch)
    assert isinstance(pieced, PiecewiseSpectra)
    np.testing.assert_array_equal(pieced.rr, alone.rr)  # the same segments in the same order
    assert pieced.segments == alone.segments and pieced.equivalent_segments == alone.equivalent_segments
    for i in range(model.n_outputs):
        row, reference = pieced.row(i), alone.row(i)
        for name in ("zy", "zx", "yy", "xy", "xx"):
            np.testing.assert_array_equal(getattr(row, name), getattr(reference, name), err_msg=name)

        def doubled(x, u):  # the transform takes the row regressors and the inputs
            return 2.0 * x

        np.testing.assert_array_equal(pieced.instrument_cross(i, doubled), alone.instrument_cross(i, doubled))


def test_a_window_solves_each_row_once_for_its_fit_and_its_data_quality(job):
    from pmr_ros.core.pmr.implicit import implicit_row, instrument_factor, row_estimate, row_layout, spectra_factor

    stretches = window_stretches(job, 0, 3 * DAY - 1)
    model, welch = job.config.model, WelchSettings(segment_length=256)
    alone = RecordSpectra(stretches, model, welch)
    factor = instrument_factor(alone.rr)
    np.testing.assert_array_equal(spectra_factor(alone), factor)
    with PieceCache(model).window(stretches, stretch_spans(job, 0, 3 * DAY - 1)):
        pieced = record_spectra(stretches, model, welch)
        assert spectra_factor(pieced) is spectra_factor(pieced)  # kept for the window
        for i in range(model.n_outputs):
            columns = row_layout(model, i, **alone.layout_inputs).columns
            reference = implicit_row(alone.row(i), alone.rr, factor, columns)
            kept = row_estimate(pieced, i, columns)
            assert row_estimate(pieced, i, columns, row=pieced.row(i)) is kept  # the second asker gets the first's
            for name in ("ratio", "coherence", "condition", "power", "explained"):
                np.testing.assert_array_equal(getattr(kept, name), getattr(reference, name), err_msg=name)
                np.testing.assert_array_equal(getattr(row_estimate(alone, i, columns), name), getattr(reference, name))
            fewer = row_estimate(pieced, i, columns[:1])  # other regressors: solved on their own
            np.testing.assert_array_equal(fewer.ratio, implicit_row(alone.row(i), alone.rr, factor, columns[:1]).ratio)


def test_a_filtering_transform_of_stretches_of_several_lengths_is_the_same(job):
    # stretches of one length are filtered in one call (stacked on axis 1); a short stretch in its own group
    from dataclasses import replace

    from scipy.signal import lfilter

    usable = job.usable.copy()
    usable[DAY + 300 : DAY + 310] = False  # day 1 split in two stretches of other lengths
    cut = replace(job, usable=usable)
    spans = stretch_spans(cut, 0, 3 * DAY - 1)
    assert len({b - a for a, b in spans}) == 3
    stretches = window_stretches(cut, 0, 3 * DAY - 1)
    model, welch = cut.config.model, WelchSettings()
    alone = RecordSpectra(stretches, model, welch)
    with PieceCache(model).window(stretches, spans):
        pieced = record_spectra(stretches, model, welch)

    def filtered(x, u):  # a first-order filter of each regressor along time, from rest, plus the inputs
        return lfilter([0.3, 0.1], [1.0, -0.6], x, axis=0) + 0.5 * u

    for i in range(model.n_outputs):
        np.testing.assert_array_equal(pieced.instrument_cross(i, filtered), alone.instrument_cross(i, filtered))


def test_data_a_window_does_not_hold_are_computed_as_usual(job):
    stretches = window_stretches(job, 0, 2 * DAY - 1)
    model = job.config.model
    pieces = PieceCache(model)
    with pieces.window(stretches, stretch_spans(job, 0, 2 * DAY - 1)):
        other = window_stretches(job, 2 * DAY, 3 * DAY - 1)  # new arrays the window does not know
        assert type(record_spectra(other, model, WelchSettings())) is RecordSpectra
        assert pieces.spectra(stretches, model, WelchSettings()) is not None
        another = model.with_mismatch(Mismatch.zero(model.n_outputs, model.n_inputs))  # e.g. augmented with DVs
        assert pieces.spectra(stretches, another, WelchSettings()) is None
    assert type(record_spectra(stretches, model, WelchSettings())) is RecordSpectra  # outside the block: as usual


def test_a_window_keeps_only_its_own_pieces(job):
    model = job.config.model
    pieces = PieceCache(model)
    for start in range(3):
        first, last = start * DAY, (start + 2) * DAY - 1
        stretches = window_stretches(job, first, last)
        with pieces.window(stretches, stretch_spans(job, first, last)):
            record_spectra(stretches, model, WelchSettings()).row(0)
        held = {key[0] for key in pieces._store}
        assert held == set(stretch_spans(job, first, last))  # the day before the window was dropped


def test_first_order_zi_is_lfilter_zi():
    rng = np.random.default_rng(3)
    for _ in range(200):
        a, ah, lin = rng.uniform(0.0, 0.999), rng.uniform(0.0, 0.999), rng.normal()
        numerator, denominator = lin * (1.0 - a) / (1.0 - ah) * np.array([1.0, -ah]), np.array([1.0, -a])
        np.testing.assert_array_equal(_first_order_zi(numerator, denominator), lfilter_zi(numerator, denominator))
    second = (np.array([1.0, 0.5, 0.2]), np.array([1.0, -0.3, 0.1]))
    np.testing.assert_array_equal(_first_order_zi(*second), lfilter_zi(*second))


def test_mixture_interval_of_one_normal_is_its_central_interval():
    # a mixture of two equal normals is that normal: mean +- 1.96 sd (scipy.stats.norm)
    low, high = mixture_interval(np.array([1.0, 1.0]), np.array([0.5, 0.5]), np.array([0.3, 0.7]), level=0.95)
    np.testing.assert_allclose([low, high], [1.0 - 1.959964 * 0.5, 1.0 + 1.959964 * 0.5], rtol=1e-6)


@pytest.mark.parametrize(("samples", "stretches", "columns", "length"), [(1340, 14, 1, 512), (900, 3, 2, 256)])
def test_stacked_segment_ffts_are_each_blocks_segment_spectra(samples, stretches, columns, length):
    """Stretches of one length in one call: each one's Welch segments as its own call gives them (means its own)."""
    rng = np.random.default_rng(stretches)
    blocks = np.cumsum(rng.standard_normal((samples, stretches, columns)), axis=0) + 5.0 * np.arange(stretches)[:, None]
    welch = WelchSettings(segment_length=length)
    stacked = stacked_segment_ffts(blocks, welch)
    for j in range(stretches):
        alone = segment_spectra(blocks[:, j], welch).ffts
        assert stacked[j].shape == alone.shape
        np.testing.assert_allclose(stacked[j], alone, rtol=1e-13, atol=1e-12)
