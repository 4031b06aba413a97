"""The thin rclpy shell of pmr_ros: node base, parameters, message builders, QoS, signals.

Nothing here computes: the numerics live in :mod:`pmr_ros.core`, the
contract's plain-data side in :mod:`pmr_ros.contract`.
"""
