"""A ProB2-UI project's validation table (``tracecheck project``) for people and machines:
a table fitted to the terminal with each task's numbers and reasons under it, one table for
Markdown and CSV with every field, and the JSON report (the library's own ``to_json``)."""

from __future__ import annotations

from ..errors import printable
from .emit import Report
from .tables import TableData, fitted, markdown, md_text, terminal_width, wrapped

__all__ = ["ProjectOutput"]

_TYPES = {"REPLAY_TRACE": "trace replay", "HYPOTHESIS_TEST": "hypothesis test",
          "ESTIMATION": "estimation", "MONTE_CARLO_SIMULATION": "Monte Carlo"}


def _type(kind: str) -> str:
    return _TYPES.get(kind, kind)


def _first_line(text: str) -> str:
    return text.splitlines()[0] if text else ""


def _project_table(report) -> TableData:
    """Every task with every field, for Markdown and CSV (reasons whole, on one line)."""
    return TableData.of(
        ["machine", "task", "type", "checks", "executions", "status", "result", "reason",
         "source", "where"],
        ([t.machine, t.task, t.kind, t.checks, t.executions, t.status, t.result,
          " ".join(t.reason.split()), t.source, t.where] for t in report.tasks))


def _project_summary(report) -> str:
    """One line: how many tasks succeeded, failed, were not run."""
    counts = {s: report.count(s) for s in ("success", "failed", "not run")}
    deselected = sum(1 for t in report.tasks if not t.selected)
    line = (f"{counts['success']} succeeded, {counts['failed']} failed, {counts['not run']} "
            f"not run, of {len(report.tasks) - deselected} tasks")
    if deselected:
        line += f" ({deselected} more deselected in the project)"
    return line


def _project_text(console, report) -> None:
    """The validation table fitted to the terminal (the formula column cut when it must be),
    then per task its numbers and, where it failed or did not run, why; a summary last.
    Everything printed as it is (no markup)."""
    width = terminal_width()
    machines = list(dict.fromkeys(t.machine for t in report.tasks))
    first = ["machine"] if len(machines) > 1 else []
    table = TableData.of(
        [*first, "task", "type", "runs", "verdict", "checks"],
        ([*([t.machine] if first else []), t.task, _type(t.kind), t.executions or "",
          t.status, t.checks] for t in report.tasks))
    heading = f"{report.project} ({report.file})"
    if len(machines) == 1:
        heading += f", machine {machines[0]}"
    console.print(printable(heading), markup=False)
    for line in fitted(table, width, shrink=len(table.headers) - 1):
        console.print(line, markup=False)
    notes = []
    for t in report.tasks:
        text = t.result
        if t.reason and t.status != "success":
            why = _first_line(t.reason)
            text = f"{text}; {why}" if text and why not in text else (text or why)
        if text:
            who = f"{t.machine} {t.task}" if first else t.task
            notes.append(wrapped(f"{who} ({t.status}): {text}", width, "    "))
    if notes:
        console.print("", markup=False)
        for note in notes:
            console.print(note, markup=False)
    console.print("", markup=False)
    console.print(_project_summary(report), markup=False)


class ProjectOutput(Report):
    """``project``'s report in every format (Markdown: the table, then the summary)."""

    def __init__(self, report) -> None:
        self.report = report

    def data(self):
        return self.report.to_json()

    def table(self) -> TableData:
        return _project_table(self.report)

    def markdown(self) -> str:
        return markdown(self.table()) + "\n\n" + md_text(_project_summary(self.report),
                                                         cell=False)

    def summary(self) -> str:
        """One line: how many tasks succeeded, failed and were not run."""
        return _project_summary(self.report)

    def text(self, console) -> None:
        _project_text(console, self.report)
