"""The thin rclpy shell of pmr_ros: node base, parameters, message builders, QoS, signals.

``base`` what every node shares (declared parameters, contract topics, start
and stop), ``parameters`` the declarations as ROS descriptors, ``convert``
results and arrays into messages, ``messages`` message classes and QoS
profiles, ``flow`` lockstep flow control, ``followers`` which subscribers a
replay left behind, ``signals`` Ctrl-C and SIGTERM, ``worker`` the slow jobs'
thread.  Each module is imported on its own (they load rclpy).

Nothing here computes: the numerics live in :mod:`pmr_ros.core`, the
contract's plain-data side in :mod:`pmr_ros.contract`.
"""
