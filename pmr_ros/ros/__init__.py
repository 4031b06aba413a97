"""The thin ROS 2 shell of pmr_ros: topic contract, message conversion, parameters, node set.

Nothing here computes: the numerics live in :mod:`pmr_ros.core`.  Modules that
need rclpy import it themselves, so ``pmr_ros.ros.alignment`` stays usable
without ROS.
"""
