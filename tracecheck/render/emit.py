"""One protocol for everything a command prints, and the one function that writes it in any
``--format``.

A result a command prints is wrapped in a :class:`Report`: its data for JSON, its table for
Markdown and CSV, its text for people. :func:`emit` is the only place a format is chosen; the
commands build the report and hand it over, and neither render nor choose.

>>> from tracecheck.render.tables import TableData
>>> class Count(Report):
...     def __init__(self, n): self.n = n
...     def data(self): return {"n": self.n}
...     def table(self): return TableData.of(["n"], [[str(self.n)]])
...     def text(self, console): console.print(f"{self.n} things")
>>> emit(Count(3), "json")
{
  "n": 3
}
"""

from __future__ import annotations

import sys
from typing import Any, Optional, TextIO

from ..errors import printable
from .tables import TableData, csv_text, markdown

__all__ = ["Report", "emit", "FORMATS"]

#: the formats every report takes: for people, a Markdown table, CSV, the full JSON
FORMATS = ("text", "md", "csv", "json")


class Report:
    """What a command prints (subclasses give :meth:`data`, :meth:`table` and
    :meth:`text`; :meth:`markdown` and :meth:`csv` default to the table's)."""

    def data(self) -> Any:
        """The full result as JSON-ready data (``--format json``)."""
        raise NotImplementedError

    def table(self) -> TableData:
        """The result as one table (``--format md`` and ``csv``: every row)."""
        raise NotImplementedError

    def text(self, console) -> None:
        """The result for people on ``console`` (a rich console), fitted to the terminal."""
        raise NotImplementedError

    def markdown(self) -> str:
        """``--format md``: the table as Markdown (a report may add a summary)."""
        return markdown(self.table())

    def csv(self) -> str:
        """``--format csv``: the table, every row."""
        return csv_text(self.table())


def emit(report: Report, fmt: str, console=None, stream: Optional[TextIO] = None) -> None:
    """Write ``report`` in the format ``fmt`` (one of :data:`FORMATS`).

    Args:
        report: what to print.
        fmt: ``text``, ``md``, ``csv`` or ``json``.
        console: where ``text`` goes (a rich console; None: a plain one on ``stream``).
        stream: where the other formats go (default standard output).
    """
    stream = stream if stream is not None else sys.stdout
    if fmt == "json":
        from ..jsontext import json_text, write_json

        data = report.data()
        if isinstance(data, dict):  # a campaign's rows a few hundred at a time
            write_json(data, stream)
            stream.write("\n")
        else:
            stream.write(json_text(data, indent=2, ensure_ascii=False) + "\n")
    elif fmt == "md":
        stream.write(printable(report.markdown(), "\n\r\t") + "\n")
    elif fmt == "csv":
        stream.write(report.csv())
    elif fmt == "text":
        if console is None:
            from rich.console import Console

            console = Console(file=stream, highlight=False, markup=False, emoji=False)
        report.text(console)
    else:
        raise ValueError(f"unknown format {fmt!r}; the formats are {', '.join(FORMATS)}")
