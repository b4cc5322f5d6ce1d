"""The validation report: one HTML page with the replay summary, the statistics tables with
intervals, the plots (inline SVG), and links to viewer pages of the episodes that matter
(crashes, crashes the shield would have prevented, first infeasible steps)."""

from __future__ import annotations

import html
import io
from pathlib import Path
from typing import Optional, Sequence

from ..errors import InputError
from ..stats.properties import PropertySet
from ..checking.shield import Shield
from ..outputs import write_file
from .viewer import render_episode

__all__ = ["render_report"]

_STYLE = """body{font-family:system-ui,sans-serif;margin:1.5em;color:#222;max-width:1200px}
table{border-collapse:collapse;font-size:.85em;margin:.5em 0}td,th{border:1px solid #ccc;
padding:.2em .5em;text-align:left}h2{margin-top:1.5em}.note{color:#666;font-size:.85em}
figure{display:inline-block;margin:.5em}figure svg{max-width:560px;height:auto}"""


def _table(header: list[str], rows: list[list[str]]) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in row) + "</tr>"
                   for row in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def _svg_plots(result: dict) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .stats_text import stats_plots

    figures = []
    original = plt.Figure.savefig

    def capture(fig, path, *args, **kwargs):
        if kwargs.get("format") == "svg" or str(path).endswith(".svg"):
            buf = io.StringIO()
            original(fig, buf, format="svg")
            text = buf.getvalue()
            figures.append(text[text.index("<svg"):])

    plt.Figure.savefig = capture
    try:
        import tempfile

        with tempfile.TemporaryDirectory() as tmp:
            stats_plots(result, Path(tmp))
    finally:
        plt.Figure.savefig = original
    return figures


def render_report(runs: list[Path], out: Path, *, shield: Optional[Shield],
                  pset: PropertySet, max_pages: int = 20, force: bool = False,
                  inputs: Sequence[Path] = (), adapter=None) -> tuple[Path, int]:
    """Write the report to ``out`` and viewer pages beside it (``NAME_files/``); (report,
    pages written). Both follow the output rule (:mod:`tracecheck.outputs`): neither is one
    of the runs or ``inputs``, existing ones are replaced only with ``force``, and only once
    the new ones are complete."""
    from ..checking.replay import replay
    from ..outputs import check_output, safe_name
    from ..stats.estimates import statistics
    from .stats_text import _rows

    from ..episodes.columns import read_columns

    out = Path(out)
    pages_dir = out.with_name(out.stem + "_files")
    check_output(out, [*runs, *inputs], force=force, example="report.html")
    check_output(pages_dir, [*runs, *inputs], force=force, kind="folder",
                 what="folder of viewer pages", contents=("*.html",))
    for run in runs:
        if not Path(run).exists():
            raise InputError(f"no such file: {run}")
        if not len(read_columns(run).episode_ids):
            raise InputError(f"{run} holds no complete episode: nothing to report")
    parts = [f"<h1>tracecheck validation report</h1><p class='note'>runs: "
             f"{html.escape(', '.join(map(str, runs)))}</p>"]
    pages = []
    # one page name per run, also for runs with the same file name in different folders
    stems, taken = [Path(r).stem for r in runs], set()
    page_stem = {str(r): safe_name(stem if stems.count(stem) == 1 else f"{stem}_{i + 1}", taken)
                 for i, (r, stem) in enumerate(zip(runs, stems))}
    if shield is not None:
        report = replay(runs, shield)
        parts.append(f"<h2>Replay against shield {html.escape(shield.name)}</h2><p>"
                     f"{report.episodes} episode(s), {report.steps} step(s): "
                     f"{report.infeasible_steps} infeasible step(s) in "
                     f"{report.infeasible_episodes} episode(s); {report.crashes} crash(es), "
                     f"{report.crashes_after_infeasible} at or after the first infeasible step "
                     f"(would have been blocked); {report.deadlock_states} deadlock state(s), "
                     f"{report.postcondition_violations} postcondition and "
                     f"{report.invariant_violations} invariant violation(s).</p>"
                     f"<p class='note'>shield sha256 {shield.sha256}</p>")
        matters = [e for e in report.per_episode if e.crashed or e.first_infeasible is not None]
        matters.sort(key=lambda e: (not e.crash_after_infeasible, not e.crashed))
        rows = []
        for e in matters:
            link = ""
            if len(pages) < max_pages:
                stem = page_stem.get(str(e.file)) or safe_name(Path(e.file).stem)
                name = f"{stem}_episode_{e.episode}.html"
                pages.append((e.file, e.episode, name))
                link = f"{pages_dir.name}/{name}"
            rows.append((e, link))
        parts.append("<h2>Episodes that matter</h2><table><tr><th>file</th><th>episode</th>"
                     "<th>steps</th><th>first infeasible</th><th>crash step</th>"
                     "<th>crash after it</th><th>viewer</th></tr>")
        for e, link in rows:
            cell = f"<a href='{html.escape(link)}'>open</a>" if link else "(not rendered)"
            parts.append(
                f"<tr><td>{html.escape(Path(e.file).name)}</td><td>{e.episode}</td>"
                f"<td>{e.steps}</td><td>{'' if e.first_infeasible is None else e.first_infeasible}"
                f" {html.escape(e.action or '')}</td><td>{'' if e.crash_step is None else e.crash_step}"
                f"</td><td>{'yes' if e.crash_after_infeasible else ''}</td><td>{cell}</td></tr>")
        parts.append("</table>")
    result = statistics(runs, pset, adapter=adapter)
    header, rows = _rows(result)
    parts.append(f"<h2>Statistics ({html.escape(pset.name)})</h2><p class='note'>metrics: "
                 f"mean ± sd [95 % t interval]; properties: % of episodes [95 % "
                 f"{result['interval']} interval]</p>")
    parts.append(_table(header, rows))
    for svg in _svg_plots(result):
        parts.append(f"<figure>{svg}</figure>")
    page = (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>tracecheck "
            f"report</title><style>{_STYLE}</style></head><body>{''.join(parts)}</body></html>")
    if pages:
        _write_pages(pages_dir, pages, shield)
    write_file(out, page)
    return out, len(pages)


def _write_pages(folder: Path, pages: list, shield: Optional[Shield]) -> None:
    """The viewer pages, into a new folder that replaces ``folder`` once all are written."""
    from ..outputs import atomic_folder, inside, open_new

    with atomic_folder(folder) as tmp:
        for file, episode, name in pages:
            with open_new(inside(tmp, name)) as stream:
                stream.write(render_episode(file, episode, shield).encode("utf-8"))
