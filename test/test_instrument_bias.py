"""The finite-segment bias of a row's instrumental equations (:mod:`pmr_ros.core.pmr.parametric.bias`).

Synthetic segment transforms, every bin its own replicate: K independent
segments (no overlap, so the equivalent number of segments is K), n_z
instruments, a regressor that carries the noise as a closed loop's does
(``x = a v + w``) and ``y = theta x + v``.  The projected equations then miss
``b - A theta = 0`` by ``n_z conj(a)`` noise units on average; with the
residual moments' share taken out they hold, and the cost keeps its
chi-square scale (2 n_z per complex bin).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from pmr_ros.core.pmr.implicit import instrument_factor
from pmr_ros.core.pmr.parametric.bias import residual_moments, unscaled_residual_moments, without_instrument_bias
from pmr_ros.core.pmr.parametric.fit import RowFit
from pmr_ros.core.pmr.parametric.ratio import bin_scale, row_system, whitened_regressors
from pmr_ros.core.pmr.spectra import RowSpectra

K, NZ, BINS = 12, 3, 6000
A_COUPLING = 0.6 - 0.3j
THETA = 1.5 + 0.2j


def _complex(rng, *shape):
    return (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2.0)


def _spectra(seed=0):
    """RowSpectra of one regressor from K segment transforms per bin, and those transforms."""
    rng = np.random.default_rng(seed)
    z = _complex(rng, BINS, K, NZ) * np.array([1.0, 0.5, 2.0])
    v = _complex(rng, BINS, K)
    x = A_COUPLING * v + _complex(rng, BINS, K) + z @ np.array([0.8, -0.4, 0.3])
    y = THETA * x + v
    c = np.stack([y, x], axis=2)  # (F, K, 2)
    cross = np.einsum("fka,fkb->fab", z.conj(), c) / K
    moments = np.einsum("fka,fkb->fab", c.conj(), c) / K
    spectra = RowSpectra(
        zy=cross[:, :, 0],
        zx=cross[:, :, 1:],
        yy=moments[:, 0, 0].real,
        xy=moments[:, 1:, 0],
        xx=moments[:, 1:, 1:],
        differenced=False,
    )
    rr = np.einsum("fka,fkb->fab", z.conj(), z) / K
    return spectra, instrument_factor(rr), z, c


def _system(spectra, factor, corrected):
    weights = {
        "noise": np.ones(BINS),
        "bins": np.arange(BINS),
        "omega": np.linspace(0.1, 3.0, BINS),
        "equivalent_segments": float(K),
    }
    system = row_system(spectra, factor, columns=np.array([0]), **weights)
    if not corrected:
        return system
    residual = residual_moments(spectra, factor, columns=np.array([0]), **weights)
    return without_instrument_bias(system, residual, instruments=NZ, equivalent_segments=float(K))


def test_residual_moments_are_the_moments_outside_the_instruments():
    spectra, factor, z, c = _spectra()
    residual = residual_moments(
        spectra,
        factor,
        columns=np.array([0]),
        noise=np.ones(BINS),
        bins=np.arange(BINS),
        omega=np.linspace(0.1, 3.0, BINS),
        equivalent_segments=float(K),
    )
    # independently: the least-squares residual of [y, x] on the instruments over the segments
    f = 7
    fitted = z[f] @ np.linalg.lstsq(z[f], c[f], rcond=None)[0]
    outside = (c[f] - fitted).conj().T @ (c[f] - fitted) / K * (2.0 * K)
    np.testing.assert_allclose(residual[f], outside, rtol=1e-9, atol=1e-9)


def test_the_corrected_equations_hold_at_the_true_parameters():
    spectra, factor, _, _ = _spectra()
    raw, fixed = _system(spectra, factor, False), _system(spectra, factor, True)
    theta = np.full((BINS, 1), THETA)
    # b - A theta seen through A: A^H (b - A theta) = v - M theta, per bin, in whitened units (scale^2 = 2K)
    miss_raw = (raw.v - np.einsum("fkm,fm->fk", raw.M, theta))[:, 0]
    miss_fixed = (fixed.v - np.einsum("fkm,fm->fk", fixed.M, theta))[:, 0]
    spread = np.std(miss_fixed) / np.sqrt(BINS)
    # uncorrected: n_z conj(a) sigma_v^2 scale^2 / K = 2 n_z conj(a) on average
    np.testing.assert_allclose(miss_raw.mean(), 2.0 * NZ * np.conj(A_COUPLING), atol=5.0 * spread)
    np.testing.assert_allclose(miss_fixed.mean(), 0.0, atol=5.0 * spread)


def test_the_corrected_cost_keeps_its_chi_square_scale():
    spectra, factor, _, _ = _spectra(1)
    theta = np.full((BINS, 1), THETA)
    for corrected in (False, True):
        system = _system(spectra, factor, corrected)
        per_bin = system.cost(theta) / BINS
        np.testing.assert_allclose(per_bin, 2.0 * NZ, rtol=0.05, err_msg=f"corrected={corrected}")


def test_too_few_segments_leave_the_equations_as_they_are():
    spectra, factor, _, _ = _spectra()
    system = _system(spectra, factor, False)
    residual = np.ones((BINS, 2, 2))
    assert without_instrument_bias(system, residual, instruments=NZ, equivalent_segments=NZ + 1.0) is system


def test_the_delay_likelihood_is_tempered_by_the_bin_correlation():
    fit = RowFit(
        lin=np.ones(1),
        s=np.zeros(1),
        delays=np.zeros(1, dtype=int),
        sd_lin=np.ones(1),
        sd_s=np.ones(1),
        chi_square=300.0,
        dof=100,
        delay_profile=({0: 300.0},),
        lack_of_fit=np.ones(1),
        columns=(),
        bin_correlation=1.94,
    )
    np.testing.assert_allclose(fit.scale, 3.0 * 1.94, rtol=1e-12)
    # a reduced chi-square below one does not sharpen it
    np.testing.assert_allclose(replace(fit, chi_square=50.0).scale, 1.94, rtol=1e-12)


def test_the_unweighted_parts_are_kept_once_and_give_the_same_equations():
    """What a row's fit keeps once (whitened regressors, unscaled residual moments) gives the same equations.

    The same as computing them again at every weighting.
    """
    spectra, factor, z, _ = _spectra(seed=3)
    bins, omega = np.arange(0, BINS, 7), np.linspace(0.1, 3.0, BINS)
    noise = np.exp(np.sin(omega))  # any positive weights
    weights = {"noise": noise, "bins": bins, "omega": omega, "equivalent_segments": float(K)}
    columns = np.array([0])
    whitened = whitened_regressors(spectra, factor, columns=columns, bins=bins)
    # the whitened regressors are L^-1 S_zx: L whitened L^H = S_zz's factor times S_zx
    np.testing.assert_allclose(factor[bins] @ whitened, spectra.zx[bins][:, :, columns], rtol=1e-10, atol=1e-12)
    alone = row_system(spectra, factor, columns=columns, **weights)
    kept = row_system(spectra, factor, columns=columns, whitened=whitened, **weights)
    for name in ("M", "v", "beta"):
        np.testing.assert_allclose(getattr(kept, name), getattr(alone, name), rtol=1e-13, atol=1e-13)
    scale = bin_scale(noise, bins=bins, omega=omega, equivalent_segments=float(K))
    unscaled = unscaled_residual_moments(spectra, factor, columns=columns, bins=bins)
    np.testing.assert_allclose(
        unscaled * (scale**2)[:, None, None],
        residual_moments(spectra, factor, columns=columns, **weights),
        rtol=1e-13,
        atol=1e-13,
    )
