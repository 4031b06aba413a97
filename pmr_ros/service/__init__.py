"""Orchestration shared by the nodes, the ``pmr-ros`` commands and the Python API.

Each flow here strings the layers below together once: ``closing`` the control
impact of a verdict and the corrected model it proposes (live node, ``run``,
``diagnose``).  The commands only parse arguments and print; the nodes only
convert messages and keep time.
"""

__all__: list[str] = []
