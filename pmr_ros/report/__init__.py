"""Diagnosis reports: the JSON document (``document``) and the verdict table people read (``table``)."""

from .document import build_report, injected_mismatch, write_json
from .table import format_table

__all__ = ["build_report", "format_table", "injected_mismatch", "write_json"]
