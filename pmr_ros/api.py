"""The Python front door: load a configuration, simulate a closed loop, diagnose arrays, a bag or a historian file.

Each function strings together the layers a command would (the core, the
configuration, :mod:`pmr_ros.service`), so a script needs one import; the
names are re-exported by :mod:`pmr_ros` itself.  Nothing here imports rclpy:
a bag is read with rosbags.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .config import PmrConfig, load_config
from .core.pmr.diagnosis import diagnose_stretches
from .core.records import Record
from .core.results import Diagnosis
from .core.sim.augment import missing_disturbances
from .core.sim.closed_loop import simulate as simulate_loop
from .core.sim.model import Mismatch, TransferMatrix

__all__ = ["Simulation", "diagnose", "diagnose_bag", "diagnose_file", "load_config", "simulate"]


@dataclass(frozen=True)
class Simulation:
    """A simulated closed-loop run and the truth it was made with.

    Attributes
    ----------
    record : Record
        Setpoints, inputs, outputs and dither, one row per sample.
    config : PmrConfig
        The configuration run (the controller's model is ``config.model``).
    plant : TransferMatrix
        The true plant the loop ran on.
    injected : Mismatch
        The mismatch injected into the plant (``gain_pct``, ``time_constant_pct``,
        ``delay_samples`` per element): what a diagnosis should find.
    """

    record: Record
    config: PmrConfig
    plant: TransferMatrix
    injected: Mismatch


def _config(config: PmrConfig | str | Path | None) -> PmrConfig:
    return config if isinstance(config, PmrConfig) else load_config(config)


def simulate(
    config: PmrConfig | str | Path | None = None,
    *,
    samples: int | None = None,
    seed: int | None = None,
    scenario: str | None = None,
) -> Simulation:
    """Run the configured closed loop in batch (PRBS setpoints, MPC on the model, the true plant).

    Parameters
    ----------
    config : PmrConfig or path, optional
        A configuration or a params file (default: the shipped Wood-Berry column).
    samples, seed, scenario : optional
        Override ``run.samples``, ``run.seed`` and ``run.scenario`` (which part of
        the configured mismatch the plant gets: ``full``, ``gain`` ...).

    Returns
    -------
    Simulation
        The record, the plant and the injected mismatch.
    """
    config = _config(config)
    scenario = scenario or config.run.scenario
    record = simulate_loop(config, samples=samples, seed=seed, scenario=scenario)
    return Simulation(record, config, config.plant(scenario), config.mismatch.for_scenario(scenario))


def diagnose(
    r: np.ndarray,
    u: np.ndarray,
    y: np.ndarray,
    *,
    config: PmrConfig | str | Path | None = None,
    model: TransferMatrix | None = None,
    method: str | None = None,
    dither: np.ndarray | None = None,
    dv: np.ndarray | None = None,
) -> Diagnosis:
    """Diagnose one gap-free record of closed-loop data: a verdict per element of the model.

    Parameters
    ----------
    r, u, y : ndarray, shapes (N, n_outputs), (N, n_inputs), (N, n_outputs)
        Setpoints, inputs applied and measured outputs, one row per sample.
    config : PmrConfig or path, optional
        The PMR settings (and the model, unless ``model`` is given); default
        the shipped configuration.
    model : TransferMatrix, optional
        The controller's model ``Ghat`` (default ``config.model``).
    method : str, optional
        ``classic`` or ``parametric`` (default ``pmr.method`` of the configuration).
    dither : ndarray, shape (N, n_inputs), optional
        The MV dither added to the controller's outputs, if any.
    dv : ndarray, shape (N, n_disturbances), optional
        The measured disturbances of the configuration's ``disturbance_model``:
        its D elements (``D11`` ...) are diagnosed beside the G elements.

    Returns
    -------
    Diagnosis
        With the data-quality figures of the configuration's ``quality`` block.

    Raises
    ------
    ValueError
        The configuration has measured disturbances and ``dv`` does not carry them (one line).
    """
    config = _config(config)
    applied_dither = None if dither is None else np.asarray(dither)
    record = Record(np.asarray(r), np.asarray(u), np.asarray(y), applied_dither, None if dv is None else np.asarray(dv))
    problem = missing_disturbances([record], config.disturbance_model)
    if problem:
        raise ValueError(problem)
    return diagnose_stretches(
        [record],
        model=model or config.model,
        pmr=config.pmr,
        parametric=config.parametric,
        method=method,
        quality=config.quality,
        disturbance_model=config.disturbance_model,
    )


def diagnose_bag(
    path: str | Path,
    *,
    config: str | Path | None = None,
    method: str | None = None,
    namespace: str | None = None,
    min_samples: int | None = None,
) -> Diagnosis:
    """Diagnose a rosbag2 bag offline as the live diagnostician did; the diagnosis of its last window.

    Parameters
    ----------
    path : str or Path
        The bag directory (or an .mcap file).
    config : path, optional
        A params file with the controller's model (default: the bag's recorded configuration).
    method, namespace, min_samples : optional
        As ``pmr-ros diagnose BAG --method/--namespace/--min-samples``.

    Raises
    ------
    pmr_ros.bag.storage.BagError
        A missing topic, no configuration, or one whose channels are not the bag's.

    See Also
    --------
    pmr_ros.service.bag_diagnosis.diagnose_bag : every window and the comparison with the recorded verdicts.
    """
    from .bag.reader import open_bag
    from .service.bag_diagnosis import diagnose_bag as diagnose_recording

    config_path = None if config is None else str(config)
    result = diagnose_recording(open_bag(path), config_path, method, min_samples=min_samples, namespace=namespace)
    return result.final_diagnosis


def diagnose_file(path: str | Path, *, config: PmrConfig | str | Path, method: str | None = None) -> Diagnosis:
    """Diagnose a historian export (CSV or Parquet): read, cleaned, one estimate over its clean stretches.

    Parameters
    ----------
    path : str or Path
        The export (columns named by the configuration's ``data`` block).
    config : PmrConfig or path
        The controller's model and the ``data`` block.
    method : str, optional
        ``classic`` or ``parametric`` (default ``pmr.method``).

    Raises
    ------
    pmr_ros.service.refusal.ServiceError
        Bad data (one line naming the file, column, row and value).
    """
    from dataclasses import replace

    from .service.historian import diagnose_table

    config = _config(config)
    if method is not None:
        config = replace(config, pmr=replace(config.pmr, method=method))
    return diagnose_table(path, config).diagnosis
