"""The numerical core, free of ROS and of configuration files, by subject.

``sim`` the model, the true plant, the excitation and the closed loop in
batch; ``mpc`` the controller; ``pmr`` the plant-model ratio diagnosis (classic
and parametric); ``loop`` what follows a verdict (control impact, corrected
model, judging a live update).  Every subject reads and writes the one data
record, :class:`~pmr_ros.core.records.Record`, and the result types of
:mod:`pmr_ros.core.results`.
"""
