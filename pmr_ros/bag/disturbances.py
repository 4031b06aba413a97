"""Which measured disturbances (DVs) a bag gives the offline diagnosis: the configuration's, on ``pmr/disturbance``.

The DVs are read only when the configuration declares them (its disturbance
model, or ``system.disturbance_names``) and the bag holds the contract topic;
then every sample needs them, as it needs r, u and y (:attr:`Record.dv`).
"""

from __future__ import annotations

from ..config import PmrConfig
from ..config.data import configured_disturbances
from ..contract.topics import DISTURBANCE_TOPIC, topic
from .reader import Bag

__all__ = ["DISTURBANCE_KEY", "config_disturbances", "disturbance_topic"]

DISTURBANCE_KEY = DISTURBANCE_TOPIC
"""Contract key of the measured disturbances (DVs)."""


def config_disturbances(config: PmrConfig) -> tuple[str, ...]:
    """The DV names of a configuration: its disturbance model's inputs, else ``system.disturbance_names``."""
    return configured_disturbances(config)


def disturbance_topic(bag: Bag, config: PmrConfig, namespace: str = "/") -> str | None:
    """The bag's DV topic when the configuration declares DVs and the bag holds it (else None: no ``Record.dv``)."""
    name = topic(DISTURBANCE_KEY).resolved(namespace)
    return name if config_disturbances(config) and name in bag.topics else None
