"""The time-constant sweep of the paper's sections 3.4-3.6 (Figs. 2-7).

``plan`` says what to run, ``tuning`` keeps the MPC stable as a time constant
grows, ``execute`` runs the closed loops (lockstep batches, one process per
core) and appends every estimate to a CSV (``store``), and ``analysis``
reduces the CSV to medians and breakdown points.  The figures and the
markdown report are :mod:`pmr_ros.report` (``sweep_document`` and its
parts).  Nothing here imports rclpy.
"""

from .plan import DEFAULT_ELEMENTS, SweepPlan, SweepPoint, nu_grid, parse_nu_list

__all__ = ["DEFAULT_ELEMENTS", "SweepPlan", "SweepPoint", "nu_grid", "parse_nu_list"]
