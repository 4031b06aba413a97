"""pmr_ros: model-plant mismatch diagnosis for MPC with the plant-model ratio."""

__version__ = "0.1.0"
