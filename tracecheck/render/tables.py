"""Tables for machines and documents: one typed table per command, written as Markdown or CSV.

Every command that prints a table for people (rich text, fitted to the terminal) builds the
same rows here with full names, so ``--format md`` and ``--format csv`` give the whole
table, unabbreviated, and ``--format json`` the command's full report.
"""

from __future__ import annotations

import csv
import io
import shutil
import textwrap
from dataclasses import dataclass

__all__ = ["TableData", "markdown", "csv_text", "fitted", "wrapped", "terminal_width"]


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
        return cls(tuple(str(h) for h in headers),
                   tuple(tuple("" if c is None else str(c) for c in row) for row in rows))


def _md_cell(text: str) -> str:
    return text.replace("\\", "\\\\").replace("|", "\\|").replace("\n", "<br>")


def markdown(table: TableData) -> str:
    """A GitHub-flavoured Markdown table (``|`` and line breaks in cells escaped)."""
    lines = ["| " + " | ".join(_md_cell(h) for h in table.headers) + " |",
             "|" + "---|" * len(table.headers)]
    lines += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in table.rows]
    return "\n".join(lines)


def csv_text(table: TableData) -> str:
    """RFC 4180 CSV with a header row (``\\r\\n`` line ends, as the csv module writes)."""
    buf = io.StringIO()
    writer = csv.writer(buf)
    writer.writerow(table.headers)
    writer.writerows(table.rows)
    return buf.getvalue()


def fitted(table: TableData, width: int, shrink: int = 0) -> list[str]:
    """The table as aligned lines of at most ``width`` characters for a terminal: cells are
    never wrapped or broken; only column ``shrink`` (a file name, say) is cut, ending in
    "…", when the line would be too wide (it keeps at least 8 characters)."""
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
    return textwrap.fill(line, width, subsequent_indent=indent, break_long_words=False,
                         break_on_hyphens=False)
