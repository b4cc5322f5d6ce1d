"""Bridges to the ProB toolset: SimB timed traces and ProB2 trace files, both ways."""

from .prob2trace import export_prob2trace, import_prob2trace
from .simb import export_simb, import_simb

__all__ = ["import_simb", "export_simb", "import_prob2trace", "export_prob2trace"]
