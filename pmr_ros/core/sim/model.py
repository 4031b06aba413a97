"""Transfer-function matrices of MPC models: FOPTD, integrating and empty elements.

Each element is one of :data:`ELEMENT_TYPES`:

* ``foptd``: ``G_ik(s) = K exp(-theta s) / (tau s + 1)``; sampled with a
  zero-order hold at ``Ts`` and a delay of whole samples ``d = theta / Ts`` it
  is exactly ``G_ik(z) = b z^-(1 + d) / (1 - a z^-1)``, ``a = exp(-Ts / tau)``,
  ``b = K (1 - a)``, so ``y(k) = a y(k-1) + b u(k-1-d)``;
* ``integrating`` (a level, a gas pressure: a "ramp" CV): ``K exp(-theta s)/s``,
  K in output units per input unit per time unit; sampled, ``a = 1`` and
  ``b = K Ts``: ``y(k) = y(k-1) + K Ts u(k-1-d)``;
* ``none``: an empty cell, no model (``b = 0``).

Frequencies are in rad/sample.

A model may carry its measured disturbances (DVs) as its last input columns
(:func:`~pmr_ros.core.sim.augment.augmented_model`: ``[G, Gd]``,
:attr:`TransferMatrix.n_disturbances` of them): their elements are named
``D11``, ``D12`` ...
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from ..results import ElementModel
from .foptd_matrix import DiscreteFoptd, StateSpace, foptd_state_space
from .lti import Element, Empty, Foptd, Integrating
from .mismatch import SCENARIOS, Mismatch

__all__ = ["SCENARIOS", "DiscreteFoptd", "Mismatch", "StateSpace", "TransferMatrix", "element_name"]

ELEMENT_TYPES = ("foptd", "integrating", "none", "tf", "step_response")
"""The kinds of element a model may hold."""

"""Mismatch scenarios of the paper's Table 2: which parts of a mismatch apply."""


def element_name(i: int, k: int, n: int, *, prefix: str = "G") -> str:
    """Name of element (i, k), zero-based: ``G11`` style, ``G1_10`` when n > 9; ``D11`` with ``prefix="D"`` (a DV's).

    Examples
    --------
    >>> element_name(0, 1, 2), element_name(9, 2, 10, prefix="D")
    ('G12', 'D10_3')
    """
    if n > 9:
        return f"{prefix}{i + 1}_{k + 1}"
    return f"{prefix}{i + 1}{k + 1}"


@dataclass(frozen=True)
class TransferMatrix:
    """An n_outputs x n_inputs matrix of FOPTD, integrating and empty elements with a sample time.

    Attributes
    ----------
    gain : ndarray, shape (n_outputs, n_inputs)
        K [output unit / input unit; per time unit for an integrating element].
    time_constant : ndarray
        tau [time unit of ``sample_time``], > 0 for FOPTD elements; NaN for
        integrating and empty ones (they have none).
    delay : ndarray
        Dead times theta [time unit], whole multiples of ``sample_time``; 0 for empty cells.
    sample_time : float
        Ts [time unit].
    output_names, input_names : tuple of str
        Channel names, used on topics and in reports.
    name : str
        Name of the system.
    element_type : ndarray of str
        One of :data:`ELEMENT_TYPES` per element; default (empty): all ``foptd``.
    n_disturbances : int
        How many of the last input columns are measured disturbances (DVs),
        the feedforward model ``Gd`` beside ``G`` (:func:`~pmr_ros.core.sim.augment.augmented_model`); 0: none.
    general : tuple of tuple of (Element or None)
        Per cell, the element itself where its type is ``tf`` or
        ``step_response`` (its gain is then the element's steady-state gain,
        its delay the element's, its time constant NaN); None elsewhere.
        Empty (the default): no such element.  Build with :meth:`of_elements`.
    """

    gain: np.ndarray
    time_constant: np.ndarray
    delay: np.ndarray
    sample_time: float
    output_names: tuple[str, ...] = field(default=())
    input_names: tuple[str, ...] = field(default=())
    name: str = ""
    element_type: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=object))
    n_disturbances: int = 0
    general: tuple[tuple[Element | None, ...], ...] = ()

    def __post_init__(self) -> None:
        for attr in ("gain", "time_constant", "delay"):
            object.__setattr__(self, attr, np.array(getattr(self, attr), dtype=float, ndmin=2))
        shape = self.gain.shape
        if self.time_constant.shape != shape or self.delay.shape != shape:
            raise ValueError("gain, time_constant and delay must have the same shape")
        given = np.array(self.element_type, dtype=object)
        kinds = np.full(shape, "foptd", dtype=object) if given.size == 0 else given
        if kinds.shape != shape or not set(kinds.ravel()) <= set(ELEMENT_TYPES):
            raise ValueError(f"element_type must be {shape} entries of {', '.join(ELEMENT_TYPES)}")
        object.__setattr__(self, "element_type", kinds)
        self._check_general(shape)
        # what an element does not have is not there: no time constant off FOPTD, nothing in an empty cell
        object.__setattr__(self, "time_constant", np.where(kinds == "foptd", self.time_constant, np.nan))
        empty = kinds == "none"
        object.__setattr__(self, "gain", np.where(empty, 0.0, self.gain))
        object.__setattr__(self, "delay", np.where(empty, 0.0, self.delay))
        if not self.output_names:
            object.__setattr__(self, "output_names", tuple(f"y{i + 1}" for i in range(shape[0])))
        if not self.input_names:
            object.__setattr__(self, "input_names", tuple(f"u{k + 1}" for k in range(shape[1])))

    def _check_general(self, shape: tuple[int, ...]) -> None:
        """Every ``tf``/``step_response`` cell holds its element and no other cell does."""
        cells = [[None] * shape[1] for _ in range(shape[0])] if not self.general else self.general
        if len(cells) != shape[0] or any(len(row) != shape[1] for row in cells):
            raise ValueError(f"general must be {shape} cells of Element or None")
        general_kind = np.isin(self.element_type, ("tf", "step_response"))
        held = np.array([[c is not None for c in row] for row in cells], dtype=bool).reshape(shape)
        if (held != general_kind).any():
            raise ValueError("general must hold an Element exactly where element_type is tf or step_response")
        object.__setattr__(self, "general", tuple(tuple(row) for row in cells))

    @classmethod
    def of_elements(
        cls,
        elements: Sequence[Sequence[Element]],
        *,
        sample_time: float,
        output_names: tuple[str, ...] = (),
        input_names: tuple[str, ...] = (),
        name: str = "",
        n_disturbances: int = 0,
    ) -> TransferMatrix:
        """The matrix of ``elements`` (rows of :class:`~pmr_ros.core.sim.lti.Element`), any type mixed.

        Parameters
        ----------
        elements : sequence of sequence of Element
            ``elements[i][k]`` is ``G_ik``; every one sampled at ``sample_time``.
        sample_time : float
            Ts [time unit].
        output_names, input_names, name, n_disturbances
            As the attributes.

        Returns
        -------
        TransferMatrix

        Raises
        ------
        ValueError
            Rows of different lengths, or an element at another sample time.
        """
        from .realize import cell_arrays

        gain, tau, delay, kinds, general = cell_arrays(elements, sample_time=sample_time)
        return cls(
            gain,
            tau,
            delay,
            sample_time,
            output_names,
            input_names,
            name,
            kinds,
            n_disturbances,
            tuple(tuple(row) for row in general),
        )

    def element_rows(self) -> list[list[Element]]:
        """Every cell's :meth:`element`, row by row (what :mod:`.realize` takes)."""
        return [[self.element(i, k) for k in range(self.n_inputs)] for i in range(self.n_outputs)]

    @property
    def has_general(self) -> bool:
        """Whether any element is a ``tf`` or ``step_response`` (no FOPTD shortcut applies then)."""
        return any(c is not None for row in self.general for c in row)

    @property
    def n_outputs(self) -> int:
        """Controlled outputs (rows)."""
        return self.gain.shape[0]

    @property
    def n_inputs(self) -> int:
        """Manipulated inputs (columns)."""
        return self.gain.shape[1]

    @property
    def delay_samples(self) -> np.ndarray:
        """Dead times in whole samples (int)."""
        return np.rint(self.delay / self.sample_time).astype(int)

    @property
    def present(self) -> np.ndarray:
        """Where the model has an element (not ``none``), shape (n_outputs, n_inputs)."""
        return np.asarray(self.element_type != "none")

    @property
    def integrating(self) -> np.ndarray:
        """Where the element is integrating (an ``integrating`` one, a tf with an integrator, a ramp curve)."""
        ramps = [[c is not None and c.integrating for c in row] for row in self.general] if self.has_general else False
        return np.asarray((self.element_type == "integrating") | np.array(ramps, dtype=bool))

    @property
    def integrating_outputs(self) -> np.ndarray:
        """Outputs with at least one integrating element ("ramp" CVs), shape (n_outputs,)."""
        return np.asarray(self.integrating.any(axis=1))

    @property
    def slowest_time_constant(self) -> float:
        """The largest FOPTD time constant [time unit], 0 when there is none."""
        tau = self.time_constant[self.element_type == "foptd"]
        return float(tau.max()) if tau.size else 0.0

    def element_names(self) -> list[str]:
        """Row-major element names ``G11, G12, ...`` (``G1_10`` style beyond 9 channels); ``D11 ...`` for DV columns.

        The G names are those of the model without its DVs; a DV column's
        element is ``D<row><dv>`` (``D10_3`` style beyond 9 outputs or DVs).
        """
        mvs = self.n_inputs - self.n_disturbances
        n, n_dv = max(self.n_outputs, mvs), max(self.n_outputs, self.n_disturbances)
        return [
            element_name(i, k, n) if k < mvs else element_name(i, k - mvs, n_dv, prefix="D")
            for i in range(self.n_outputs)
            for k in range(self.n_inputs)
        ]

    def element_models(self) -> dict[str, tuple[int, int, ElementModel]]:
        """Row-major element name to ``(row, column, ElementModel)``, as diagnoses report them."""
        delays = self.delay_samples
        out = {}
        for j, name in enumerate(self.element_names()):
            i, k = divmod(j, self.n_inputs)
            tau = float(self.time_constant[i, k])
            element = ElementModel(
                str(self.element_type[i, k]), float(self.gain[i, k]), None if np.isnan(tau) else tau, int(delays[i, k])
            )
            out[name] = (i, k, element)
        return out

    def element(self, i: int, k: int) -> Element:
        """The element ``G_ik`` as an :class:`~pmr_ros.core.sim.lti.Element`, sampled and scaled alike for every type.

        Parameters
        ----------
        i, k : int
            Row (output) and column (input), from 0.

        Returns
        -------
        Element
            :class:`~pmr_ros.core.sim.lti.Foptd`, :class:`~pmr_ros.core.sim.lti.Integrating`,
            :class:`~pmr_ros.core.sim.lti.Empty`, or the ``tf``/``step_response`` element held.
        """
        kind = self.element_type[i, k]
        held = self.general[i][k]
        if held is not None:
            return held
        delay = int(self.delay_samples[i, k])
        if kind == "foptd":
            return Foptd(float(self.gain[i, k]), float(self.time_constant[i, k]), delay, self.sample_time)
        if kind == "integrating":
            return Integrating(float(self.gain[i, k]), delay, self.sample_time)
        return Empty(self.sample_time)

    def settling_samples(self, time_constants: float = 8.0) -> int:
        """Samples until every element forgets its initial state to ``exp(-time_constants)``.

        ``time_constants`` x the largest FOPTD tau plus the largest delay, in
        samples; a ``tf``/``step_response`` element's own
        :meth:`~pmr_ros.core.sim.lti.Element.settle_samples` at that fraction
        when longer.  (An integrating element never forgets; its data are differenced instead.)
        """
        settle = int(np.ceil(time_constants * self.slowest_time_constant / self.sample_time))
        general = [c.settle_samples(float(np.exp(-time_constants))) for row in self.general for c in row if c]
        return max(settle + int(self.delay_samples.max()) + 1, *general, 0)

    def discretize(self) -> DiscreteFoptd:
        """Exact zero-order-hold discretization with the delay in whole samples."""
        with np.errstate(divide="ignore", invalid="ignore"):
            pole = np.where(self.element_type == "foptd", np.exp(-self.sample_time / self.time_constant), 0.0)
        pole = np.where(self.integrating, 1.0, pole)
        numerator = np.where(self.integrating, self.gain * self.sample_time, self.gain * (1.0 - pole))
        return DiscreteFoptd(pole, np.where(self.present, numerator, 0.0), self.delay_samples)

    def with_mismatch(self, mismatch: Mismatch) -> TransferMatrix:
        """The plant ``G`` that differs from this model by ``mismatch``.

        A ``tf``/``step_response`` element is scaled as a whole
        (:meth:`~pmr_ros.core.sim.lti.Element.scaled`: its time-constant change
        is its dynamics change alpha - 1); integrating elements have no time constant to change.
        """
        if self.has_general:
            return self._with_general_mismatch(mismatch)
        return replace(
            self,
            gain=self.gain * (1.0 + mismatch.gain_pct / 100.0),
            time_constant=self.time_constant * (1.0 + mismatch.time_constant_pct / 100.0),
            delay=self.delay + mismatch.delay_samples * self.sample_time,
        )

    def _with_general_mismatch(self, mismatch: Mismatch) -> TransferMatrix:
        """:meth:`with_mismatch` cell by cell through :meth:`element` and ``scaled``.

        An integrating element's gain change is that of its ramp rate: time
        scaling by alpha divides the ramp rate by alpha, so rho is alpha (1 + dK).
        """
        return self.with_elements(
            [[self._scaled_cell(i, k, mismatch) for k in range(self.n_inputs)] for i in range(self.n_outputs)]
        )

    def with_elements(self, rows: Sequence[Sequence[Element]]) -> TransferMatrix:
        """A model with the same names, sample time and DV count around other elements ``rows[i][k]``."""
        return TransferMatrix.of_elements(
            rows,
            sample_time=self.sample_time,
            output_names=self.output_names,
            input_names=self.input_names,
            name=self.name,
            n_disturbances=self.n_disturbances,
        )

    def _scaled_cell(self, i: int, k: int, mismatch: Mismatch) -> Element:
        """Element (i, k) with its share of ``mismatch`` (see :meth:`_with_general_mismatch`)."""
        element = self.element(i, k)
        alpha = 1.0 if self.element_type[i, k] == "integrating" else 1.0 + mismatch.time_constant_pct[i, k] / 100.0
        rho = (1.0 + mismatch.gain_pct[i, k] / 100.0) * (alpha if element.integrating else 1.0)
        delay = int(mismatch.delay_samples[i, k]) if self.present[i, k] else 0
        return element.scaled(gain_ratio=rho, time_scale=alpha, delay_change=delay)

    def with_time_constant(self, i: int, k: int, time_constant: float) -> TransferMatrix:
        """A copy with element (i, k)'s time constant replaced [time unit]."""
        tau = self.time_constant.copy()
        tau[i, k] = time_constant
        return replace(self, time_constant=tau)

    def state_space(self) -> StateSpace:
        """Discrete realization ``x+ = A x + B u``, ``y = C x`` with one shift register per input.

        FOPTD, integrating and empty elements only: one first-order state per
        element that is there (row-major), reading the register tap of its
        delay (:func:`~.foptd_matrix.foptd_state_space`, stepped with two
        multiplications per state).  With ``tf`` or ``step_response`` elements
        (:attr:`has_general`): :func:`~.realize.realize` of :meth:`element_rows`.
        """
        if self.has_general:
            from .realize import realize

            return StateSpace(*realize(self.element_rows()))
        return foptd_state_space(self.discretize(), self.present)

    def element_outputs(self, u: np.ndarray) -> np.ndarray:
        """Per-element model outputs ``yhat_ik = G_ik u_k``.

        Parameters
        ----------
        u : ndarray, shape (N, n_inputs)
            Inputs.  FOPTD filters start at steady state for ``u[0]``; the true
            initial state is unknown, so drop the first :meth:`settling_samples`
            of the result before using it.  Integrating filters start at zero
            (they have no steady state); empty cells give zeros.

        Returns
        -------
        ndarray, shape (N, n_outputs, n_inputs)
        """
        from scipy.signal import lfilter, lfilter_zi

        u = np.asarray(u, dtype=float)
        if self.has_general:
            from .realize import element_outputs

            return element_outputs(self.element_rows(), u)
        disc = self.discretize()
        out = np.zeros((u.shape[0], self.n_outputs, self.n_inputs))
        present = self.present
        for i in range(self.n_outputs):
            for k in range(self.n_inputs):
                if not present[i, k]:
                    continue
                b, a = disc.filter_coefficients(i, k)
                zi = np.zeros(len(b) - 1) if self.integrating[i, k] else lfilter_zi(b, a) * u[0, k]
                out[:, i, k] = lfilter(b, a, u[:, k], zi=zi)[0]
        return out
