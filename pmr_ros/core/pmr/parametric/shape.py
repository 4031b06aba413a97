"""Whether an element's plant differs from its model in shape, and its gain read where the shape does not matter.

An element whose best scaled model does not fit the data beyond noise --
its own lack of fit above ``parametric.lack_of_fit_max``, or its row's
beyond noise with its own above 1 (:data:`ROW_MISFIT_Z`) -- is a
:func:`shape_misfit`: speed and delay bend to mimic a shape, so neither can
be read (:mod:`.verdicts` makes them inconclusive with :data:`SHAPE_REASON`);
its gain is judged on the hull of its fitted interval and the one read at the
lowest fitted bin alone (:func:`steady_state_interval`), where the ratio is the
gain ratio whatever the shape.
"""

from __future__ import annotations

from scipy.stats import norm

from .fit import RowFit
from .settings import ParametricSettings

__all__ = ["ROW_MISFIT_Z", "SHAPE_REASON", "shape_misfit", "shape_reason", "steady_state_interval"]

SHAPE_REASON = "the plant's response differs in shape, not only in gain, speed or delay"
"""The reason of an element whose best scaled model does not fit the data beyond noise."""


ROW_MISFIT_Z = 2.5
"""A row whose reduced chi-square lies this many standard deviations above 1 (:attr:`~.fit.RowFit.misfit_z`)
does not fit beyond noise: its elements that fit worse than their noise (lack of fit > 1) are judged as
shape misfits though their own lack of fit stays below ``parametric.lack_of_fit_max``.

One element's misfit spreads over the row's residual, and a fit whose speed and delay bend to mimic a
shape still follows each element's free estimate to within a few times its noise (measured: a
second-order plant under its best FOPTD model, at low noise, row z 2.6-4.9, element lack of fit 1.2-2.8,
a confident delay change of one sample in a quarter of the seeds without this rule); rows of the right
structure stay within +-1.1 (Wood-Berry closed loop), so a real change is rarely held back."""


def shape_misfit(fit: RowFit, c: int, settings: ParametricSettings) -> bool:
    """Whether column ``c`` does not fit beyond noise: its own lack of fit, or the row's with its own above 1.

    Its own: further from the per-bin free estimate than ``parametric.lack_of_fit_max``; the row's:
    :data:`ROW_MISFIT_Z`.
    """
    own = float(fit.lack_of_fit[c])
    return not own <= settings.lack_of_fit_max or (fit.misfit_z > ROW_MISFIT_Z and own > 1.0)


def shape_reason(fit: RowFit, c: int, settings: ParametricSettings) -> str:
    """:data:`SHAPE_REASON` with the lack of fit that shows it (column ``c``'s own, or its row's)."""
    own = float(fit.lack_of_fit[c])
    if not own <= settings.lack_of_fit_max:
        return (
            f"{SHAPE_REASON}: the fit does not follow the data ({own:.1f}x the noise > "
            f"{settings.lack_of_fit_max:g}; or a delay lies beyond pmr.max_delay_samples)"
        )
    return (
        f"{SHAPE_REASON}: the row's fit does not follow the data (reduced chi-square "
        f"{fit.chi_square / fit.dof:.2f}, {fit.misfit_z:.1f} standard deviations above 1 > {ROW_MISFIT_Z:g}; "
        f"this element {own:.1f}x its noise)"
    )


def steady_state_interval(fit: RowFit, c: int, settings: ParametricSettings) -> tuple[float, float] | None:
    """Column ``c``'s gain change [%] read at the lowest fitted bin alone, as an interval; None when not kept.

    At w = 0 (the lowest nonzero bin of a differenced row) every shape is 1:
    the coefficient there is the gain ratio whatever the plant's shape
    (:attr:`~.fit.RowFit.steady_gain`).
    """
    if fit.steady_gain is None or fit.steady_gain_sd is None:
        return None
    z = float(norm.ppf(0.5 + settings.confidence_level / 2.0))
    gain, sd = float(fit.steady_gain[c]), float(fit.steady_gain_sd[c])
    return 100.0 * (gain - z * sd - 1.0), 100.0 * (gain + z * sd - 1.0)
