"""Proof and symbolic-diff results (``prove``, ``diff --symbolic``) for people and machines:
lines for the terminal, one table for Markdown and CSV, and the JSON report."""

from __future__ import annotations

from typing import Optional

from rich.console import Console

from ..b.notation import to_json
from ..checking.proving import VACUOUS, Result
from .emit import Report
from .tables import TableData

__all__ = ["ProveOutput"]


def _decisions(extra: Optional[dict]) -> str:
    """Which shield enables the operation in a distinguishing state (``diff --symbolic``)."""
    extra = dict(extra or {})
    action = extra.pop("action", None)  # an operation with REAL parameters: which action
    text = ", ".join(f"{k} {'allows' if action else 'enables'} it" if v else
                     f"{k} {'refuses' if action else 'blocks'} it" for k, v in extra.items())
    if action:
        shown = ", ".join(f"{p} = {v!r}" for p, v in action.items())
        return f"the action {shown}: {text}"
    return text


def _prove_json(results: list[Result], written: dict[int, str]) -> list[dict]:
    """Each result as JSON, with the file its counterexample was written to (``written``:
    {result index: path})."""
    return [{
        "obligation": r.obligation, "status": r.status, "reason": r.reason or None,
        "reading": r.reading or None, "disagreement": r.disagreement or None,
        "decisions": r.extra or None, "counterexample_file": written.get(i),
        "state": {k: to_json(v) for k, v in r.state.items()} if r.state else None,
    } for i, r in enumerate(results)]


def _prove_table(results: list[Result], written: dict[int, str]) -> TableData:
    """One row per result, for Markdown and CSV."""
    return TableData.of(
        ["obligation", "status", "reason", "reading", "decisions", "counterexample file"],
        ([r.obligation, r.status, r.reason, r.reading, _decisions(r.extra), written.get(i)]
         for i, r in enumerate(results)))


def _prove_text(console: Console, results: list[Result], written: dict[int, str]) -> None:
    """A line per result (vacuity said once, first), its reading, the shields' decisions
    and its counterexample file indented under it; names printed as they are."""
    vacuous = next((r.reason for r in results if r.status == VACUOUS), None)
    if vacuous:
        console.print(f"{VACUOUS}: {vacuous}", markup=False)
    for i, r in enumerate(results):
        line = f"{r.obligation}: {r.status}"
        if r.reason and r.status != VACUOUS:
            line += f" ({r.reason})"
        console.print(line, markup=False)
        if r.reading:
            console.print(f"  {r.reading}", markup=False)
        if r.extra:
            console.print("  " + _decisions(r.extra), markup=False)
        if i in written:
            console.print(f"  state: {written[i]}", markup=False)


class ProveOutput(Report):
    """``prove``'s and ``diff --symbolic``'s results in every format (``written``: the
    counterexample file of each result that has one, by its index)."""

    def __init__(self, results: list[Result], written: dict[int, str]) -> None:
        self.results, self.written = results, written

    def data(self):
        return _prove_json(self.results, self.written)

    def table(self) -> TableData:
        return _prove_table(self.results, self.written)

    def text(self, console) -> None:
        _prove_text(console, self.results, self.written)
