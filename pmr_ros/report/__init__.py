"""Every report people read, each rendered from the result objects.

A diagnosis: the JSON document (``document``), the verdict table in a
terminal (``table``), the HTML page (``html`` with ``figures``, ``curves``,
``page``).  The sweep: the markdown reproduction report (``sweep_document``)
with its figures (``sweep_figures``), tables (``sweep_tables``), findings
(``sweep_findings``) and the paper's reference numbers (``sweep_paper``).
"""

from .document import build_report, injected_mismatch, write_json
from .table import format_table

__all__ = ["build_report", "format_table", "injected_mismatch", "write_json"]
