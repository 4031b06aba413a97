"""The four executables of the node set: plant, setpoint generator, controller, diagnostician.

Each module holds one small node class and a ``main(args=None)``; they only
declare parameters, convert messages, keep time and call :mod:`pmr_ros.core`.
"""
