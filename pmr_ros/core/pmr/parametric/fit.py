"""Fitting one output row: the delay search, the two-pass noise estimate, the profile, the covariance.

:func:`fit_row` runs, for one output row of the implicit regression,

1. the column-by-column global search over whole-sample delays and time
   constants (:mod:`.search`), weighted with the noise spectrum of the
   nonparametric estimate, then the joint fit of every continuous parameter
   (:class:`~.lsq.RowProblem`);
2. the same fit again with the noise spectrum re-estimated from the first
   fit's residual (the weights of the final fit);
3. the profile of each column's delay over its neighbours, the others held
   at their best (a neighbour that fits better is taken; not an empty cell's
   interaction that is absent), and the joint search of coupled pairs;
4. gains and time constants refitted at the chosen delays with the Welch
   segments' leakage taken out of the equations (:func:`leakage_offset`);
5. the Gauss-Newton covariance, inflated by the Welch window's bin correlation
   and by the reduced chi-square when that exceeds one;
6. each column's lack of fit: how far the fitted coefficient lies from the
   per-bin free estimate, in units of that estimate's noise (first-pass
   weights, which the fit's own misfit has not inflated).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .lsq import RowParameters, RowProblem
from .parameterization import absence_z, column_models, interaction_delay_range
from .profile import DelaySearch, search_delays, uncertainty
from .rank import first_pass
from .ratio import ColumnModel, RowSystem
from .rowdata import RowData
from .search import column_grids, sweep_columns
from .separation import Separation, separation
from .trials import Trials, alternatives, joint_profiles

__all__ = [
    "LEAKAGE_ROUNDS",
    "LEAKAGE_SETTLED",
    "RowData",
    "RowFit",
    "WeightedFit",
    "column_models",
    "fit_row",
    "interaction_delay_range",
    "leakage_offset",
]

LEAKAGE_ROUNDS = 2
"""Refits with the segments' leakage taken out, each at the last fit's parameters (:func:`leakage_offset`).

At most: a round that moves no parameter by :data:`LEAKAGE_SETTLED` of its deviation is the last.
Measured on the Skogestad LV column: a third round moves no parameter by a hundredth of its deviation."""

LEAKAGE_SETTLED = 0.05
"""A leakage round that moves every parameter by less than this share of its standard deviation ends the rounds.

The next round would move them far less: on 44 rows of a 4x8 monitor's windows, the second round's move was
0.02 of the first's (median; at most 0.18), and where the first moved less than 0.05 deviations (84 % of the
rows) the second moved at most 0.0014 of one.  The deviations here are uninflated (the smallest), so that
the test is the stricter one."""


@dataclass(frozen=True)
class WeightedFit:
    """A competing delay vector of a row and its fit: a component of the intervals' mixture.

    Attributes
    ----------
    weight : float
        Likelihood weight relative to the chosen fit (<= 1 up to rounding).
    lin, s : ndarray, shape (n,)
        Its fitted parameters (as :class:`RowFit`).
    delays : ndarray of int, shape (n,)
    sd_lin, sd_s : ndarray, shape (n,)
        Their standard deviations, inflated as the fit's.
    """

    weight: float
    lin: np.ndarray
    s: np.ndarray
    delays: np.ndarray
    sd_lin: np.ndarray
    sd_s: np.ndarray


@dataclass(frozen=True)
class RowFit:
    """The fitted parameters of one output row and their uncertainty.

    Attributes
    ----------
    lin : ndarray, shape (n,)
        ``rho = K / Khat`` of an element, ``gamma`` of an interaction.
    s : ndarray, shape (n,)
        ``log(tau / tau_reference)`` (0 without a time constant).
    delays : ndarray of int, shape (n,)
        ``dD`` of an element, ``D`` of an interaction.
    sd_lin, sd_s : ndarray, shape (n,)
        Standard deviations, inflated (``sd_s`` NaN without a time constant;
        an interaction's time constant is held, so its gain's is conditional on it).
    chi_square : float
        Weighted squared residual at the fit.
    dof : int
        Its degrees of freedom.
    delay_profile : tuple of dict
        Per column: ``delay -> chi_square`` with the others at their best; empty for an interaction that was
        not profiled (an absent interaction: :func:`.profile.absent`).
    lack_of_fit : ndarray, shape (n,)
        Mean squared distance of the fit from the free estimate per bin, in its noise units (about 1 when it fits).
    columns : tuple of ColumnModel
    separation : Separation or None
        How well the data separate each column from the others (:mod:`.separation`).
    alternatives : tuple of WeightedFit
        The other delay vectors whose likelihood weight relative to the fit is
        at least :data:`~.trials.ALTERNATIVE_WEIGHT_MIN`: the intervals are
        mixtures over them and the fit (:mod:`.verdicts`).
    steady_gain, steady_gain_sd : ndarray, shape (n,), or None
        Each column's coefficient at the lowest fitted bin alone (the per-bin
        free estimate, its fitted delay's phase taken off: the gain ratio
        whatever the plant's shape) and its standard deviation; None: not kept.
    bin_correlation : float
        Of the Welch window (1: bins independent): the likelihood's tempering
        beside the reduced chi-square (:attr:`scale`), and the correlation
        :attr:`misfit_z` counts.
    """

    lin: np.ndarray
    s: np.ndarray
    delays: np.ndarray
    sd_lin: np.ndarray
    sd_s: np.ndarray
    chi_square: float
    dof: int
    delay_profile: tuple[dict[int, float], ...]
    lack_of_fit: np.ndarray
    columns: tuple[ColumnModel, ...]
    separation: Separation | None = None
    alternatives: tuple[WeightedFit, ...] = ()
    steady_gain: np.ndarray | None = None
    steady_gain_sd: np.ndarray | None = None
    bin_correlation: float = 1.0

    @property
    def scale(self) -> float:
        """What the likelihood is tempered by: the reduced chi-square (>= 1) times the bin correlation.

        The chi-square counts every bin as independent; neighbouring bins of a
        Welch window repeat each other (``bin_correlation``, 1.94 for Hann), so
        a chi-square difference between two delay vectors overstates the
        evidence by that factor, as the information overstates the precision
        (the covariance is inflated by the same factor).
        """
        return self.bin_correlation * max(1.0, self.chi_square / self.dof)

    @property
    def misfit_z(self) -> float:
        """How far the row's reduced chi-square lies above 1, in its standard deviations under a fitting model.

        ``(chi2/dof - 1) / sqrt(2 b / dof)``, b the bin correlation (neighbouring
        bins repeat each other, so the sum has ``dof / b`` independent terms).
        Measured: within +-1.1 on the Wood-Berry closed loop and below 0 on
        step tests of tf models fitted with the right structure; 2.6-4.9 on
        the low-noise rows of a second-order plant under its best FOPTD model
        whose elements' own lack of fit (1.2-2.8) stays below ``lack_of_fit_max``.
        """
        return (self.chi_square / self.dof - 1.0) / math.sqrt(2.0 * self.bin_correlation / self.dof)


def leakage_offset(data: RowData, problem: RowProblem, params: RowParameters) -> np.ndarray:
    """What the Welch segments' edges add to ``S_{z y}`` beyond ``sum_k theta_k(w) S_{z x_k}``, shape (F, n_z).

    At the fitted bins ``data.bins``, 0 at the others (no fit reads them).

    A segment's transform of ``y = theta(q) x`` is not ``theta(w)`` times the
    transform of ``x``: the response inside a segment to the input before it,
    and the part of its own input's response that falls after it, differ (the
    leakage of a system with memory, of order ``tau / segment_length``).  It
    is no noise: it follows the regressors, and a row whose inputs move
    nearly together (an ill-conditioned column) passes it to the ratios
    many times over -- measured on the Skogestad LV column, every row-1
    parameter 0.6-1.4 pp low at any record length, one to two standard
    deviations.  Here the row's model output is filtered in the time domain
    over whole stretches (no edges) and crossed with the instruments over the
    same segments; its difference from the product in the frequency domain is
    the leakage at ``params``.  Taken out of ``S_{z y}``, the equations hold
    at the true parameters without noise; the fit follows the leakage of its
    own parameters over :data:`LEAKAGE_ROUNDS` (:func:`fit_row`'s pass 3).

    Raises
    ------
    ValueError
        ``data`` has no record.
    """
    if data.record is None:
        raise ValueError("leakage_offset needs the record the spectra come from (RowData.record)")
    columns = problem.columns

    def model_output(x: np.ndarray, u: np.ndarray) -> np.ndarray:
        # one stretch (N, n_in) or several of one length stacked on axis 1 (N, S, n_in): filtered along axis 0
        total = np.zeros(x.shape[:-1])
        for c, (column, k) in enumerate(zip(columns, data.columns, strict=True)):
            lin, s, delay = float(params.lin[c]), float(params.s[c]), int(params.delays[c])
            if column.scaled is None:
                total += column.response(x[..., k], lin=lin, s=s, delay=delay)
            else:  # a scaled column filters its input, one stretch at a time
                signal = u[..., k].reshape(u.shape[0], -1)
                each = [column.response(signal[:, j], lin=lin, s=s, delay=delay) for j in range(signal.shape[1])]
                total += np.stack(each, axis=1).reshape(total.shape)
        return total[..., None]

    bins = data.bins  # the fit reads the equations there only
    exact = data.record.instrument_cross(data.row, model_output, bins)[:, :, 0]
    theta = problem.coefficients(params, np.exp(-1j * data.omega[bins])).theta
    offset = np.zeros(data.spectra.zy.shape, dtype=complex)
    offset[bins] = exact - np.einsum("fzk,fk->fz", data.spectra.zx[bins][:, :, data.columns], theta)
    return offset


def _lack_of_fit(system: RowSystem, problem: RowProblem, params: RowParameters) -> np.ndarray:
    """Per column: mean over bins of ``|free - fitted|^2 / var(free)`` (complex variance ``2 [M^-1]_kk``)."""
    free, variance = system.free_estimate()
    theta = problem.coefficients(params).theta
    return np.mean(np.abs(free - theta) ** 2 / (2.0 * variance), axis=0)


def _steady_gain(system: RowSystem, delays: np.ndarray) -> dict[str, np.ndarray]:
    """Per column: the free estimate at the lowest fitted bin with the delay's phase taken off, and its deviation.

    As :class:`RowFit`'s ``steady_gain`` and ``steady_gain_sd``.

    The real part's variance is ``[M^-1]_kk`` at a complex bin and at the (real) zero-frequency bin alike
    (:func:`~.ratio.row_system` whitens both so).
    """
    free, variance = system.free_estimate()
    turn = system.z_inv[0] ** (-np.asarray(delays, dtype=float))
    return {"steady_gain": np.real(free[0] * turn), "steady_gain_sd": np.sqrt(variance[0])}


def _weighted(trials: Trials, chosen: RowParameters, *, scale: float, inflation: float) -> tuple[WeightedFit, ...]:
    """The delay vectors other than ``chosen`` that keep a likelihood weight, with their fits' deviations."""
    out = []
    for alternative in alternatives(trials, scale=scale):
        if np.array_equal(alternative.params.delays, chosen.delays):
            continue
        sd_lin, sd_s = uncertainty(trials.problem, alternative.params, inflation)
        params = alternative.params
        out.append(WeightedFit(alternative.weight, params.lin, params.s, params.delays, sd_lin, sd_s))
    return tuple(out)


def _without_leakage(
    data: RowData, problem: RowProblem, params: RowParameters, cost: float
) -> tuple[RowProblem, RowParameters, float]:
    """The segments' leakage at the fit taken out of S_zy, gains and time constants refitted at ``params``' delays.

    The leakage moves with the fit: :data:`LEAKAGE_ROUNDS` rounds follow it (none without the record).
    """
    z_inv = np.exp(-1j * data.omega)
    for _ in range(LEAKAGE_ROUNDS if data.record is not None else 0):
        offset = leakage_offset(data, problem, params)
        problem = problem.with_system(data.system(problem.coefficients(params, z_inv).theta, offset))
        before = params
        params, cost = problem.fit(params)
        if _settled(problem, before, params):
            break
    return problem, params, cost


def _settled(problem: RowProblem, before: RowParameters, after: RowParameters) -> bool:
    """Whether no fitted parameter moved by :data:`LEAKAGE_SETTLED` of its (uninflated) deviation."""
    sd_lin, sd_s = uncertainty(problem, after, 1.0)
    free = problem.free_tau
    with np.errstate(divide="ignore", invalid="ignore"):  # a deviation of 0 (never settled) or inf (settled)
        moves = np.concatenate(
            [np.abs(after.lin - before.lin) / sd_lin, np.abs(after.s[free] - before.s[free]) / sd_s[free]]
        )
    return bool(np.all(moves < LEAKAGE_SETTLED))


def fit_row(
    data: RowData,
    columns: Sequence[ColumnModel],
    *,
    theta_start: np.ndarray,
    joint_correlation: float,
    confidence_level: float,
) -> RowFit:
    """Fit every coefficient of one output row (see the module docstring).

    Parameters
    ----------
    data : RowData
    columns : sequence of ColumnModel
        One per column of ``data.columns``.
    theta_start : ndarray of complex, shape (F, n)
        A first estimate of the row (the nonparametric one) for the first noise spectrum.
    joint_correlation, confidence_level : float
        ``parametric.joint_delay_correlation`` and ``parametric.confidence_level`` (:class:`.DelaySearch`).

    Returns
    -------
    RowFit
    """
    # pass 1: weights from the nonparametric estimate's residual; delays searched
    first, as_is = data.systems(theta_start)  # as_is: without the bias correction, for the lack of fit
    problem = RowProblem(first, columns)
    grids = column_grids(columns, first.z_inv)
    fit = first_pass(problem, grids, columns, sweep_columns(first, grids))
    # pass 2: weights from the first fit's residual; delays profiled, coupled pairs searched jointly
    z_inv = np.exp(-1j * data.omega)
    second = data.system(problem.coefficients(fit[0], z_inv).theta)
    searched = problem.with_system(second)
    trials = Trials(searched, grids)
    dof = max(1, second.components - len(columns) - searched.free_tau.size)
    search = DelaySearch(joint_correlation, absence_z(columns, confidence_level=confidence_level), data.bin_correlation)
    params, cost = search_delays(trials, trials.full(fit[0]), dof=dof, search=search)
    searched_scale = data.bin_correlation * max(1.0, cost / dof)
    # pass 3: the delays' profile and alternatives stay pass 2's: a correction made at one delay vector would
    # favour it over the others
    final, params, cost = _without_leakage(data, searched, params, cost)
    inflation = data.bin_correlation * max(1.0, cost / dof)
    sd_lin, sd_s = uncertainty(final, params, inflation)
    return RowFit(
        lin=params.lin,
        s=params.s,
        delays=params.delays,
        sd_lin=sd_lin,
        sd_s=sd_s,
        chi_square=cost,
        dof=dof,
        delay_profile=joint_profiles(trials, params, profiled=search.profiled),
        lack_of_fit=_lack_of_fit(as_is, problem, params),
        columns=tuple(columns),
        separation=separation(final, params),
        alternatives=_weighted(trials, params, scale=searched_scale, inflation=inflation),
        **_steady_gain(first, params.delays),
        bin_correlation=data.bin_correlation,
    )
