"""What a time-constant sweep runs: elements, the nu grid, scenarios, seeds."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.sim.model import SCENARIOS, TransferMatrix

DEFAULT_ELEMENTS = ("G11", "G21")
"""The paper's two sweeps: tau11 -> 16.7 nu (eq. 18) and tau21 -> 10.9 nu (eq. 19).

The paper's Figs. 5-7 are captioned G12, but its section 3.5 and eq. (19)
change G21 (6.6 e^-7s / (10.9 nu s + 1)); 10.9 min is tau21 of the standard
Wood-Berry matrix, so G21 is what we sweep.
"""

NU_DECIMALS = 9
"""nu values are rounded to this many decimals so a grid never carries 0.30000000000000004."""


class PlanError(ValueError):
    """The sweep's request is invalid; the message says which part and why."""


def nu_grid(start: float, stop: float, step: float) -> tuple[float, ...]:
    """``start, start+step, ...`` up to and including ``stop`` (within 1e-9).

    Raises
    ------
    PlanError
        If a bound is not positive and finite, ``step <= 0`` or ``stop < start``.
    """
    for name, value in (("--nu-start", start), ("--nu-stop", stop), ("--nu-step", step)):
        if not math.isfinite(value) or value <= 0:
            raise PlanError(f"{name} must be a positive number, got {value:g}")
    if stop < start:
        raise PlanError(f"the nu grid is empty: --nu-stop {stop:g} is below --nu-start {start:g}")
    count = int(math.floor((stop - start) / step + 1e-9)) + 1
    return tuple(round(start + j * step, NU_DECIMALS) for j in range(count))


def parse_nu_list(text: str) -> tuple[float, ...]:
    """A comma-separated list of nu values (``1,2.5,4``), sorted and unique.

    Raises
    ------
    PlanError
        If the list is empty or holds a value that is not a positive number.
    """
    values = []
    for item in text.split(","):
        item = item.strip()
        if not item:
            continue
        try:
            value = float(item)
        except ValueError:
            raise PlanError(f"--nu: {item!r} is not a number") from None
        if not math.isfinite(value) or value <= 0:
            raise PlanError(f"--nu: every nu must be a positive number, got {item}")
        values.append(round(value, NU_DECIMALS))
    if not values:
        raise PlanError("--nu: the nu grid is empty")
    return tuple(sorted(set(values)))


def element_index(model: TransferMatrix, element: str) -> tuple[int, int]:
    """Zero-based (row, column) of ``element`` (``G21`` -> (1, 0)).

    Raises
    ------
    PlanError
        If the model has no such element, or it is not FOPTD (integrating
        and empty elements have no time constant to sweep; a tf or
        step_response element has no single one: the sweep is the paper's
        ``tau x nu`` of one FOPTD element, in a model that may hold elements of any type).
    """
    names = model.element_names()
    if element not in names:
        raise PlanError(
            f"unknown element {element!r} to sweep; this {model.n_outputs}x{model.n_inputs} system has "
            f"{', '.join(names)}"
        )
    i, k = divmod(names.index(element), model.n_inputs)
    kind = str(model.element_type[i, k])
    if kind != "foptd":
        sweepable = [n for n, t in zip(names, model.element_type.ravel(), strict=True) if t == "foptd"]
        what = {"none": "an empty cell", "integrating": "integrating"}.get(kind)
        why = (
            f"{what}: it has no time constant to sweep"
            if what
            else f"{kind}: it has no single time constant to sweep (the sweep multiplies one FOPTD time constant "
            "by nu, the paper's tau x nu)"
        )
        raise PlanError(
            f"element {element} is {why}; choose a FOPTD element ({', '.join(sweepable) or 'this system has none'})"
        )
    return i, k


def row_time_constant_ratio(model: TransferMatrix, i: int, k: int) -> float:
    """``tau_ik`` over the other time constants of row i (their geometric mean).

    For a 2x2 matrix this is the ratio to the one neighbour in the row, the
    quantity the paper's section 3.6 calls the time-constant difference
    (tau11/tau12 for the G11 sweep, tau21/tau22 for the G21 sweep).  Only
    the row's other FOPTD elements count (integrating and empty ones have no
    time constant); with none the ratio is 1.
    """
    others = np.delete(model.time_constant[i], k)
    row = others[np.delete(model.element_type[i], k) == "foptd"]
    if row.size == 0:
        return 1.0
    return float(model.time_constant[i, k] / np.exp(np.mean(np.log(row))))


def sweep_name(element: str) -> str:
    """The CSV's ``sweep`` label of the sweep of ``element``'s time constant."""
    return f"tau_{element}"


@dataclass(frozen=True)
class SweepPoint:
    """One nu of one sweep: the controller model and plant have ``tau_ik = base * nu``.

    Attributes
    ----------
    element : str
        The swept element, e.g. ``G11``.
    row, column : int
        Its zero-based position.
    nu : float
        The multiplication factor of the time constant.
    base_time_constant : float
        ``tau_ik`` of the configured model [time unit].
    """

    element: str
    row: int
    column: int
    nu: float
    base_time_constant: float

    @property
    def sweep(self) -> str:
        """The CSV's ``sweep`` label."""
        return sweep_name(self.element)

    @property
    def time_constant(self) -> float:
        """The swept time constant at this nu [time unit]."""
        return self.base_time_constant * self.nu

    def model(self, base: TransferMatrix) -> TransferMatrix:
        """``base`` with the swept time constant; at nu = 1 it is ``base`` itself."""
        if self.nu == 1.0:
            return base
        return base.with_time_constant(self.row, self.column, self.time_constant)


@dataclass(frozen=True)
class SweepPlan:
    """Everything a sweep runs.

    Attributes
    ----------
    elements : tuple of str
        Elements whose time constant is swept, one sweep each.
    nu : tuple of float
        The grid of multiplication factors.
    seeds : tuple of int
        Seeds of every (nu, scenario) point.
    samples : int
        Closed-loop samples per run.
    scenarios : tuple of str
        Mismatch scenarios (the paper's Table 2).
    methods : tuple of str
        Diagnosis methods applied to every run (``classic``, ``parametric``).
    """

    elements: tuple[str, ...]
    nu: tuple[float, ...]
    seeds: tuple[int, ...]
    samples: int
    scenarios: tuple[str, ...] = SCENARIOS
    methods: tuple[str, ...] = ("classic",)

    def points(self, model: TransferMatrix) -> list[SweepPoint]:
        """Every (element, nu) point, sweeps in order, nu ascending."""
        out: list[SweepPoint] = []
        for element in self.elements:
            i, k = element_index(model, element)
            base = float(model.time_constant[i, k])
            out.extend(SweepPoint(element, i, k, nu, base) for nu in self.nu)
        return out

    def runs(self) -> list[tuple[str, int]]:
        """The (scenario, seed) runs of one point."""
        return [(scenario, seed) for scenario in self.scenarios for seed in self.seeds]

    @property
    def total_runs(self) -> int:
        """Runs of the whole plan."""
        return len(self.elements) * len(self.nu) * len(self.scenarios) * len(self.seeds)
