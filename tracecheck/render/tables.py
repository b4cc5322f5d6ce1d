"""Tables for machines and documents: one typed table per command, written as Markdown or CSV.

Every command that prints a table for people (rich text, fitted to the terminal) builds the
same rows here with full names, so ``--format md`` and ``--format csv`` give the whole
table, unabbreviated, and ``--format json`` the command's full report.

Both formats are inert (docs/safety.md, "Output formats are inert"): a CSV cell of text that
a spreadsheet would evaluate (it starts with ``=``, ``+``, ``-``, ``@``, a tab or a carriage
return) gets a leading ``'`` (OWASP's rule), while a number from typed data (an int or a
finite float, ``-3.5``) stays a number; a Markdown cell shows ``|``, ``<``, ``>``, ``&``,
backticks and backslashes as the characters themselves, never as table syntax, HTML or code.
"""

from __future__ import annotations

import csv
import io
import math
import numbers
import shutil
import sys
import textwrap
from dataclasses import dataclass

from ..errors import printable

__all__ = ["TableData", "Number", "is_number", "markdown", "md_text", "csv_text", "csv_cell",
           "csv_rows", "fitted", "wrapped", "terminal_width", "plain", "say"]


class Number(str):
    """The text of a cell that holds a number from typed data (an int or a finite float):
    CSV writes it as it is, a spreadsheet reads it as that number."""


def is_number(value) -> bool:
    """A finite real number, not a bool (numpy's numbers too): shown and plotted as one."""
    return (isinstance(value, numbers.Real) and not isinstance(value, bool)  # numpy's too
            and math.isfinite(value))


#: what a cell keeps of the control characters: its line breaks and tabs are data (CSV
#: quotes them, Markdown shows them as <br>), every other one is shown as an escape
_CELL_KEEPS = "\n\r\t"


def _text_cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, Number):
        return value
    return Number(value) if is_number(value) else printable(str(value), _CELL_KEEPS)


@dataclass(frozen=True)
class TableData:
    """A header and rows of text cells (every row as long as the header)."""

    headers: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]

    def __post_init__(self) -> None:
        for row in self.rows:
            if len(row) != len(self.headers):
                raise ValueError(f"a row of {len(row)} cells under {len(self.headers)} headers")

    @classmethod
    def of(cls, headers, rows) -> TableData:
        """Cells from any values: None is empty, a number keeps its kind (see :class:`Number`),
        anything else is its ``str`` with control characters shown as escapes (a name
        from an input file never drives the terminal)."""
        return cls(tuple(printable(str(h), _CELL_KEEPS) for h in headers),
                   tuple(tuple(_text_cell(c) for c in row) for row in rows))


_MD = {"\\": "\\\\", "|": "\\|", "`": "\\`", "&": "&amp;", "<": "&lt;", ">": "&gt;",
       "\r": "<br>", "\n": "<br>"}
_MD_TABLE = str.maketrans(_MD)
_MD_LINE = str.maketrans({**_MD, "\r": " ", "\n": " "})


def md_text(text: str, *, cell: bool = True) -> str:
    r"""``text`` as Markdown that renders as exactly that text: ``|``, backticks and
    backslashes escaped with a backslash, ``& < >`` as entities (no HTML gets through); a
    line break is ``<br>`` in a table cell, a space elsewhere (``cell=False``).

    >>> print(md_text("a|b <c>\nd"))
    a\|b &lt;c&gt;<br>d
    >>> md_text("two\nlines", cell=False)
    'two lines'
    """
    return printable(str(text), _CELL_KEEPS).replace("\r\n", "\n").translate(
        _MD_TABLE if cell else _MD_LINE)


def markdown(table: TableData) -> str:
    """A GitHub-flavoured Markdown table, every cell through :func:`md_text`."""
    lines = ["| " + " | ".join(md_text(h) for h in table.headers) + " |",
             "|" + "---|" * len(table.headers)]
    lines += ["| " + " | ".join(md_text(c) for c in row) + " |" for row in table.rows]
    return "\n".join(lines)


#: what makes a spreadsheet read a cell as a formula (OWASP, "CSV Injection")
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def csv_cell(value):
    """One CSV cell: a number from typed data as it is (``-3.5`` stays a number); text, and
    a float that is not finite (``-inf`` is no number to a spreadsheet), with a ``'`` in
    front when it starts with ``= + - @``, a tab or a carriage return.

    >>> csv_cell(-3.5), csv_cell(Number("-3.5")), csv_cell("-3.5"), csv_cell("=SUM(A1:A9)")
    (-3.5, '-3.5', "'-3.5", "'=SUM(A1:A9)")
    >>> csv_cell(float("-inf")), csv_cell(None)
    ("'-inf", '')
    """
    if isinstance(value, Number) or is_number(value):
        return value
    text = "" if value is None else str(value)
    return "'" + text if text.startswith(_FORMULA_START) else text


def csv_rows(rows) -> str:
    """RFC 4180 CSV of ``rows`` (the first one the header), every cell through
    :func:`csv_cell` (``\\r\\n`` line ends, as the csv module writes)."""
    buf = io.StringIO()
    csv.writer(buf).writerows([csv_cell(c) for c in row] for row in rows)
    return buf.getvalue()


def csv_text(table: TableData) -> str:
    """The table as CSV with a header row (:func:`csv_rows`)."""
    return csv_rows([table.headers, *table.rows])


def fitted(table: TableData, width: int, shrink: int = 0) -> list[str]:
    """The table as aligned lines of at most ``width`` characters for a terminal: cells are
    never wrapped or broken; only column ``shrink`` (a file name, say) is cut, ending in
    "…", when the line would be too wide (it keeps at least 8 characters)."""
    table = TableData(tuple(map(printable, table.headers)),  # a terminal: no \r, no \t
                      tuple(tuple(map(printable, row)) for row in table.rows))
    widths = [max([len(h), *(len(row[i]) for row in table.rows)])
              for i, h in enumerate(table.headers)]
    over = sum(widths) + 2 * (len(widths) - 1) - width
    if over > 0:
        widths[shrink] = max(8, widths[shrink] - over)

    def line(cells) -> str:
        parts = []
        for i, cell in enumerate(cells):
            if len(cell) > widths[i]:
                cell = cell[: widths[i] - 1] + "…"
            parts.append(cell.ljust(widths[i]))
        return "  ".join(parts).rstrip()

    return [line(table.headers), *(line(row) for row in table.rows)]


def terminal_width() -> int:
    """The terminal's columns (``COLUMNS`` when set), 80 when there is no terminal."""
    return shutil.get_terminal_size((80, 24)).columns


def wrapped(line: str, width: int, indent: str = "  ") -> str:
    """``line`` wrapped between words (never inside one), later lines indented."""
    return textwrap.fill(printable(line), width, subsequent_indent=indent, break_long_words=False,
                         break_on_hyphens=False)


def plain(line: str) -> None:
    """Print one line to standard output as it is: no markup, no emoji codes, no rich —
    and no control character from an input (a B string, a name) that could drive the
    terminal: those are shown as escapes (tabs and line breaks stay, as CSV has them)."""
    sys.stdout.write(printable(line, "\n\r\t") + "\n")


def say(line: str, indent: str = "  ") -> None:
    """A message line for people, wrapped between words at the terminal's width (80 when
    there is none), later lines indented; a long file name stays whole on a line of its own."""
    plain(wrapped(line, terminal_width(), indent))
