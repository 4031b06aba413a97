"""Decentralized PI(D) loops: the ``controller`` block's settings, and their closed loop simulated on a plant.

When the plant is run by single loops (``controller.kind: pi``) rather than
by the MPC, "which mismatch matters for control" is judged with those loops:
each CV paired with one MV, each loop a velocity-form PID

``du(k) = Kc [(e(k) - e(k-1)) + Ts/Ti e(k) + Td/Ts (e(k) - 2 e(k-1) + e(k-2))]``,
``e = r - y``, ``u(k) = clip(u(k-1) + du(k), u_min, u_max)``

(ISA standard form; clipping the velocity form's output is its anti-windup:
the integral stops where the output stops).  A loop with a negative ``Kc`` is
reverse acting.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..sim.model import TransferMatrix
from ..sim.true_plant import FoptdPlant

__all__ = ["CONTROLLER_KINDS", "ControllerSettings", "PiLoop", "PiTuning", "simulate_pi"]

CONTROLLER_KINDS = ("mpc", "pi", "external")
"""What runs the plant: this tool's MPC, decentralized PI loops, or a controller this tool does not simulate."""


@dataclass(frozen=True)
class PiLoop:
    """One single loop: a CV held at its setpoint by one MV.

    Attributes
    ----------
    output, input : int
        Indices of the CV and of the MV that controls it.
    gain : float
        ``Kc`` [input unit per output unit]; negative: reverse acting.
    integral_time : float
        ``Ti`` > 0 [time unit of the model].
    derivative_time : float
        ``Td`` >= 0 [time unit]; 0: a PI loop.
    """

    output: int
    input: int
    gain: float
    integral_time: float
    derivative_time: float = 0.0


@dataclass(frozen=True)
class PiTuning:
    """The PI loops and the MVs' output limits.

    Attributes
    ----------
    loops : tuple of PiLoop
        At most one loop per CV and per MV.
    u_min, u_max : ndarray, shape (n_inputs,)
        Output limits of every MV [input unit, deviation from nominal]; ``-inf``/``inf``: none.
    """

    loops: tuple[PiLoop, ...]
    u_min: np.ndarray
    u_max: np.ndarray

    @property
    def outputs(self) -> np.ndarray:
        """The controlled CVs' indices, in loop order."""
        return np.array([loop.output for loop in self.loops], dtype=int)


@dataclass(frozen=True)
class ControllerSettings:
    """The ``controller`` block: what runs the plant, for the control impact.

    Attributes
    ----------
    kind : str
        ``mpc`` (the ``mpc`` block's controller), ``pi`` (:attr:`pi`) or
        ``external`` (not simulated: no control impact).
    pi : PiTuning or None
        The loops of kind ``pi``.
    why_external : str
        Why the impact is not computed under ``external`` (one line; the
        declared reason when empty).
    """

    kind: str = "mpc"
    pi: PiTuning | None = field(default=None, compare=False)  # (its limit arrays have no truth value)
    why_external: str = ""


def _pid_increment(tuning: PiTuning, sample_time: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per loop: the weights of ``e(k)``, ``e(k-1)`` and ``e(k-2)`` in ``du(k)``."""
    kc = np.array([loop.gain for loop in tuning.loops])
    ti = np.array([loop.integral_time for loop in tuning.loops])
    td = np.array([loop.derivative_time for loop in tuning.loops])
    d = td / sample_time
    return kc * (1.0 + sample_time / ti + d), -kc * (1.0 + 2.0 * d), kc * d


def simulate_pi(tuning: PiTuning, plant: TransferMatrix, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The PI loops closed around ``plant`` (noise-free, from rest), following the setpoints ``r``.

    Parameters
    ----------
    tuning : PiTuning
    plant : TransferMatrix
        The plant the loops run on (FOPTD, integrating and empty elements).
    r : ndarray, shape (samples, n_outputs)
        Setpoints [output unit, deviation]; those of uncontrolled CVs are ignored.

    Returns
    -------
    y, u : ndarray
        Shapes (samples, n_outputs) and (samples, n_inputs): the outputs
        ``y(k)`` measured before ``u(k)`` is computed, as in a sampled loop.
    """
    samples = r.shape[0]
    process = FoptdPlant(plant, np.zeros(plant.n_outputs), 0)
    cv = tuning.outputs
    mv = np.array([loop.input for loop in tuning.loops], dtype=int)
    w0, w1, w2 = _pid_increment(tuning, plant.sample_time)
    e1 = np.zeros(cv.size)
    e2 = np.zeros(cv.size)
    u_now = np.zeros(plant.n_inputs)
    y = np.empty((samples, plant.n_outputs))
    u = np.empty((samples, plant.n_inputs))
    for k in range(samples):
        y[k] = process.output()
        e = r[k, cv] - y[k, cv]
        u_now[mv] = np.clip(u_now[mv] + w0 * e + w1 * e1 + w2 * e2, tuning.u_min[mv], tuning.u_max[mv])
        e2, e1 = e1, e
        u[k] = u_now
        process.advance(u_now)
    return y, u
