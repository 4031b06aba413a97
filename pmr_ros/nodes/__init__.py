"""The executables: one small node class and a ``main(args=None)`` per module.

``plant`` (executable ``wood_berry_plant``), ``prbs_setpoint``, ``mpc_controller``
and ``pmr_diagnostician`` form the node set; ``bag_recorder`` and
``bag_player`` record and replay it.  They only declare parameters, convert
messages, keep time and call :mod:`pmr_ros.core`.
"""
