"""The validation report: one HTML page for a supervisor.

One section per run, side by side (what was recorded, what the shield would have blocked,
and — when re-simulation ran — the headline "shield X would have prevented 5 of 6 crashes;
0 new"); the paired comparisons of the runs as sentences naming their test; the statistics
tables with intervals and the plots (inline SVG); then, per run, the episodes that matter
first (each with its picture, or its variables over time where the environment draws none,
and a link to its viewer page), the long tail collapsed. Every text from the runs is
escaped: the page is inert (docs/safety.md).
"""

from __future__ import annotations

import html
from pathlib import Path
from typing import Optional, Sequence

from ..stats.levels import SIGNIFICANCE
from ..checking.replaying import (MISMATCH, NEVER_BLOCKED, NEW_CRASH, NO_CRASH, NO_SEED,
                                NOT_PREVENTED, PREVENTED)
from ..checking.shield import Shield
from ..outputs import write_file
from .pictures import picture
from .viewer import episode_view, viewer_page

__all__ = ["render_report", "check_report_output", "comparison_sentences",
           "resimulation_headline"]

_STYLE = """body{font-family:system-ui,sans-serif;margin:1.5em;color:#222;max-width:1400px}
table{border-collapse:collapse;font-size:.85em;margin:.5em 0}td,th{border:1px solid #ccc;
padding:.2em .5em;text-align:left;vertical-align:top}h2{margin-top:1.5em}
.note{color:#666;font-size:.85em}figure{display:inline-block;margin:.5em}
figure svg{max-width:560px;height:auto}figure.wide{display:block}
figure.wide svg{max-width:100%}
.runs{display:grid;grid-template-columns:repeat(auto-fit,minmax(320px,1fr));gap:1em}
.run{border:1px solid #ddd;border-radius:6px;padding:.2em 1em .6em 1em}
.run h3{margin:.4em 0;font-size:1.05em;word-break:break-all}
.headline{font-size:1.05em;font-weight:600}.sentences li{margin:.3em 0}
details{margin:.5em 0}summary{cursor:pointer;color:#444}
td.pic svg{display:block}.bad{color:#c62828;font-weight:600}.good{color:#2e7d32;font-weight:600}"""

#: how many episodes per run are shown before the rest is collapsed
SHOWN = 8
#: rows of a run's collapsed tail of episodes that matter; the rest are counted by kind (a
#: campaign of 10^5 episodes has tens of thousands: ``replay --format csv`` lists every one)
TAIL = 500
#: significance level of the sentences
ALPHA = SIGNIFICANCE


def _e(text) -> str:
    return html.escape(str(text), quote=True)


def _table(header: list[str], rows: list[list[str]]) -> str:
    head = "".join(f"<th>{_e(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{_e(c)}</td>" for c in row) + "</tr>"
                   for row in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def _wide(svg: str, limit_pt: float = 600.0) -> bool:
    """Whether a plot is wider than a column (the property shares of many properties and
    runs): shrunk to one, its labels could not be read, so it gets the page's width."""
    import re

    found = re.match(r'<svg[^>]*\swidth="([\d.]+)pt"', svg)
    return found is not None and float(found.group(1)) > limit_pt


# ------------------------------------------------------------------ words

def _p(value: float) -> str:
    return f"p = {value:.3f}" if value >= 0.001 else "p < 0.001"


def _share(x: float) -> str:
    return f"{x:.0%}"


def resimulation_headline(shield: str, crashes: int, summary: dict) -> str:
    """"shield X would have prevented 5 of 6 crashes; 0 new" (and what did not reproduce)."""
    text = (f"shield {shield} would have prevented {summary['crashes_prevented']} of "
            f"{crashes} crash{'es' if crashes != 1 else ''}; {summary['new_crashes']} new")
    left = []
    if summary.get("mismatches"):
        left.append(f"{summary['mismatches']} episode(s) did not reproduce from their seed "
                    "and are not counted")
    if summary.get("without_seed"):
        left.append(f"{summary['without_seed']} episode(s) have no seed to re-run")
    return text + (f" ({'; '.join(left)})" if left else "")


def comparison_sentences(result: dict) -> list[str]:
    """The paired comparisons of ``statistics`` as sentences naming their test: "The share
    of episodes where … is lower in B than in A (12% vs 35%; exact McNemar test on 24 pairs
    of episodes with the same seed, p = 0.004)", or "No significant difference …"."""
    runs = {r["name"]: r for r in result.get("runs", [])}
    descriptions = result.get("descriptions", {})
    out = []
    for c in result.get("comparisons", []):
        a, b = c["runs"]
        pairs = c["pairs"]
        for name, entry in c.get("properties", {}).items():
            what = f"{name} (“{descriptions[name]}”)" if descriptions.get(name) else name
            ra = runs.get(a, {}).get("properties", {}).get(name, {}).get("ratio")
            rb = runs.get(b, {}).get("properties", {}).get(name, {}).get("ratio")
            shares = f"{_share(rb)} vs {_share(ra)}; " if ra is not None and rb is not None \
                else ""
            test = (f"{entry.get('method', 'exact McNemar')} test on {pairs} pair(s) of "
                    f"episodes with the same seed, {_p(entry['p_value'])}")
            if entry["p_value"] < ALPHA and ra is not None and rb is not None and ra != rb:
                way = "lower" if rb < ra else "higher"
                out.append(f"The share of episodes that satisfy {what} is {way} in {b} "
                           f"than in {a} ({shares}{test}).")
            else:
                out.append(f"No significant difference in the share of episodes that "
                           f"satisfy {what} between {b} and {a} ({shares}{test}).")
        for name, entry in c.get("metrics", {}).items():
            what = descriptions.get(name) or name
            diff = entry.get("mean_difference")
            tests = (("paired_t_p", "paired t-test"), ("wilcoxon_p", "Wilcoxon signed-rank test"))
            found = next(((key, test) for key, test in tests if entry.get(key) is not None), None)
            if found is None:
                out.append(f"{what}: no test between {a} and {b} "
                           f"({entry.get('mean_difference_note') or 'the paired values do not differ'}).")
                continue
            key, test = found
            pv = entry[key]
            detail = (f"mean difference {a} − {b} {diff:.3g} over {pairs} pair(s); {test}, "
                      f"{_p(pv)}")
            if pv < ALPHA and diff:
                way = "higher" if diff > 0 else "lower"
                out.append(f"{what} is {way} in {a} than in {b} ({detail}).")
            else:
                out.append(f"No significant difference in {what} between {a} and {b} "
                           f"({detail}).")
    return out


# ------------------------------------------------------------------ the report

def check_report_output(out: Path, inputs: Sequence[Path], force: bool = False) -> Path:
    """The output rule for a report and its folder of viewer pages (``NAME_files/``), before
    any work: neither may be an input, and existing ones are replaced only with ``force``.

    Returns:
        The folder of viewer pages.
    """
    from ..outputs import check_output

    out = Path(out)
    pages_dir = out.with_name(out.stem + "_files")
    check_output(out, list(inputs), force=force, example="report.html")
    check_output(pages_dir, list(inputs), force=force, kind="folder",
                 what="folder of viewer pages", contents=("*.html",))
    return pages_dir


def render_report(validation, out: Path, *, max_pages: int = 20, force: bool = False,
                  inputs: Sequence[Path] = (), adapter=None,
                  salvage: bool = False) -> tuple[Path, int]:
    """Draw a :class:`~tracecheck.stats.validation.Validation` as an HTML report at ``out``
    with viewer pages beside it (``NAME_files/``).

    Args:
        validation: what :func:`~tracecheck.stats.validation.validate` found.
        out: the report to write (the output rule: :mod:`tracecheck.outputs`).
        max_pages: the most viewer pages written.
        force: replace an existing report and folder of pages.
        inputs: the files read (never an output).
        adapter: the runs' environment adapter (draws the pictures), where given.
        salvage: as :func:`~tracecheck.episodes.reader.read_run`.

    Returns:
        (the report, how many viewer pages were written).
    """
    from ..outputs import safe_name
    from .stats_text import stats_rows, stats_svgs

    runs, shield, pset = list(validation.runs), validation.shield, validation.pset
    out = Path(out)
    pages_dir = check_report_output(out, [*runs, *inputs], force=force)
    stems, taken = [Path(r).stem for r in runs], set()
    page_stem = {str(r): safe_name(stem if stems.count(stem) == 1 else f"{stem}_{i + 1}", taken)
                 for i, (r, stem) in enumerate(zip(runs, stems))}
    checked = list(validation.checked)
    result = validation.statistics
    parts = [f"<h1>tracecheck validation report</h1><p class='note'>"
             f"{len(runs)} run(s)" + (f"; shield {_e(shield.name)} (sha256 {_e(shield.sha256)})"
                                      if shield is not None else "; no shield to replay")
             + f"; properties {_e(pset.name)}</p>",
             "<h2>Runs</h2><div class='runs'>",
             *(_run_section(c, shield) for c in checked), "</div>"]
    pages: list = []
    searches = [c for c in checked if c.header.search is not None]
    if searches:
        from .falsify_report import search_section

        parts.append("<h2>Searches</h2><p class='note'>Per optimiser, as ARCH-COMP's "
                     "falsification track reports: the searches that found a violation "
                     "and the episodes each needed to its first; the lowest objective so far "
                     "over each search (below 0: a violation).</p>")
        for c in searches:
            parts.append(search_section(c, shield, adapter, pages, page_stem, pages_dir,
                                        len(pages) + max(1, max_pages // len(checked)),
                                        salvage, SHOWN, TAIL))
    sentences = comparison_sentences(result)
    if sentences:
        parts.append("<h2>Comparison</h2><p class='note'>Runs paired episode by episode "
                     f"through their seeds; significant at the {ALPHA:g} level.</p>"
                     "<ul class='sentences'>" + "".join(f"<li>{_e(s)}</li>" for s in sentences)
                     + "</ul>")
    header, rows = stats_rows(result)
    parts.append(f"<h2>Statistics ({_e(pset.name)})</h2><p class='note'>metrics: "
                 f"mean ± sd [95 % t interval]; properties: % of episodes [95 % "
                 f"{_e(result['interval'])} interval]</p>")
    parts.append(_table(header, rows))
    parts += [("<figure class='wide'>" if _wide(svg) else "<figure>") + f"{svg}</figure>"
              for svg in stats_svgs(result)]
    if shield is not None:
        order = ("what re-simulation found: prevented, new crash, not prevented, did not "
                 "reproduce, no seed, never blocked, no crash" if validation.resimulated else
                 "crashes after a blocked step, other crashes, blocked steps")
        parts.append("<h2>Episodes that matter</h2><p class='note'>Per run, those that matter "
                     f"most first: {order}. The picture shows the state in which the shield "
                     "would first have blocked the agent's action (else the crash).</p>")
        budget = max(1, max_pages // len(checked))  # every run gets its viewer pages
        for c in checked:
            parts.append(_episodes_section(c, shield, pages, page_stem, pages_dir,
                                           len(pages) + budget, adapter, salvage))
    page = (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>tracecheck "
            f"report</title><style>{_STYLE}</style></head><body>{''.join(parts)}</body></html>")
    if pages:
        _write_pages(pages_dir, pages, shield, adapter)
    write_file(out, page)
    return out, len(pages)


def _environment(path, header) -> str:
    """The run's environment as the statistics take it (the one its file names, or the
    installed one that claims its states); an external script's is its own."""
    from ..stats.formulas import environment_of

    if header.source == "external":
        return f"the script's own (states of {header.model_name})"
    return environment_of(path)


def _agent(header) -> str:
    if header.source == "external":
        import shlex

        return "the script " + shlex.join(header.external_command or [])
    return header.agent_id or "—"


def _run_section(c: dict, shield: Optional[Shield]) -> str:
    h, r = c.header, c.replay
    rows = [("environment", _environment(c.file, h)), ("source", h.source),
            ("recorded under shield", h.shield_name or "—"), ("agent", _agent(h))]
    if r is not None:
        rows += [("episodes", r.episodes), ("steps", r.steps),
                 ("crashes", f"{r.crashes} ({_share(r.crashes / r.episodes)})"
                  if r.episodes else "0"),
                 (f"steps {shield.name} would have blocked",
                  f"{r.infeasible_steps} in {r.infeasible_episodes} episode(s)"),
                 ("crashes after a blocked step", r.crashes_after_infeasible)]
        if r.deadlock_states or r.postcondition_violations or r.invariant_violations:
            rows.append(("deadlocks / postcondition / invariant violations",
                         f"{r.deadlock_states} / {r.postcondition_violations} / "
                         f"{r.invariant_violations}"))
    body = "".join(f"<tr><th>{_e(k)}</th><td>{_e(v)}</td></tr>" for k, v in rows)
    text = f"<section class='run'><h3>{_e(Path(c.file).name)}</h3><table>{body}</table>"
    if c.resimulation is not None and not c.resimulation["resimulated"]:
        text += (f"<p class='headline'>Re-simulation: nothing to re-run, {_e(shield.name)} "
                 "would have blocked no step.</p>")
    elif c.resimulation is not None:
        text += (f"<p class='headline'>Re-simulation: "
                 f"{_e(resimulation_headline(shield.name, r.crashes, c.resimulation))}.</p>")
    elif r is not None and r.crashes and c.header.source == "external":
        text += ("<p class='note'>Whether blocking would have prevented a crash cannot be "
                 "told here: the run comes from an agent script (--external), which "
                 "tracecheck cannot re-simulate; record it again under the shield.</p>")
    elif r is not None and r.crashes and r.crashes_after_infeasible:
        text += ("<p class='note'>Whether blocking would have prevented a crash needs "
                 "re-simulation: <code>tracecheck report --resimulate</code>.</p>")
    elif r is not None and r.crashes:  # no crash came after a step the shield would block
        text += (f"<p class='note'>{_e(shield.name)} would have blocked no step before any "
                 "of these crashes: its blocking is not what they hinge on, and there is "
                 "nothing to re-simulate.</p>")
    return text + "</section>"


#: the episodes that matter, most first: by what re-simulation found (the words of
#: :data:`tracecheck.checking.replaying.OUTCOMES`), else by what the recording shows
_ORDER = {PREVENTED: 0, NEW_CRASH: 1, NOT_PREVENTED: 2, MISMATCH: 3, NO_SEED: 4,
          NEVER_BLOCKED: 5, NO_CRASH: 6, "": 7}
_GOOD, _BAD = {PREVENTED}, {NOT_PREVENTED, NEW_CRASH, MISMATCH}


def _ranked(c: dict) -> list:
    """The episodes that matter of a run, those that matter most first."""
    r = c.replay
    outcomes = r.resimulated()

    def rank(e):
        if outcomes is not None:
            return (_ORDER.get(outcomes[(e.file, e.episode)], 7), e.episode)
        return (1 if e.crash_after_infeasible else 2 if e.crashed else 3, e.episode)
    return sorted((e for e in r.per_episode if e.matters), key=rank)


def _episodes_section(c, shield, pages, page_stem, pages_dir, max_pages, adapter,
                      salvage: bool) -> str:
    """A run's episodes that matter: the crash column is replay's own (``replay`` and
    ``replay --resimulate`` print the same words), so the headline above and this table
    count the same episodes."""
    from ..outputs import safe_name
    from .text import crash_column

    from ..episodes.reader import find_episode, read_run

    ranked = _ranked(c)
    name = Path(c.file).name
    if not ranked:
        return f"<h3>{_e(name)}</h3><p>No episode crashed or had a blocked step.</p>"
    shown, paged = ranked[:SHOWN], ranked[:max(0, max_pages - len(pages))]
    # the episodes its pictures and its viewer pages show, decoded in one walk of the file
    result = read_run(c.file, {e.episode for e in shown + paged}, salvage=salvage)
    pictures = _pictures(result, shown, adapter, shield)
    crash_header, _, crash_cell = crash_column(c.replay)
    new_steps = {r["episode"]: r["new_crash_step"]
                 for r in (c.resimulation or {}).get("per_episode", [])}
    head = ["episode", "steps", "first blocked step", "crash step", crash_header,
            "picture", "viewer"]
    rows = []
    counted = ranked[SHOWN + TAIL:]
    for i, e in enumerate(ranked[:SHOWN + TAIL]):
        link = ""
        if i < len(paged):
            stem = page_stem.get(str(e.file)) or safe_name(Path(e.file).stem)
            page = f"{stem}_episode_{e.episode}.html"
            if all(page != p[-1] for p in pages):  # a search's violation may have it
                pages.append((e.file, find_episode(e.file, result, e.episode, salvage),
                              result.header, page))
            link = f"<a href='{_e(pages_dir.name + '/' + page)}'>open</a>"
        cell = verdict = crash_cell(e)
        if cell in (NEW_CRASH, NOT_PREVENTED) and new_steps.get(e.episode) is not None:
            verdict += f" (at step {new_steps[e.episode]})"
        cls = "good" if cell in _GOOD else "bad" if cell in _BAD else ""
        first = "" if e.first_infeasible is None else f"{e.first_infeasible} {e.action or ''}"
        rows.append(f"<tr><td>{e.episode}</td><td>{e.steps}</td><td>{_e(first)}</td>"
                    f"<td>{'' if e.crash_step is None else e.crash_step}</td>"
                    f"<td class='{cls}'>{_e(verdict)}</td>"
                    f"<td class='pic'>{pictures.get(e.episode, '')}</td>"
                    f"<td>{link or '(not rendered)'}</td></tr>")
    head_row = "<tr>" + "".join(f"<th>{_e(h)}</th>" for h in head) + "</tr>"
    text = (f"<h3>{_e(name)}</h3><table>{head_row}{''.join(rows[:SHOWN])}</table>")
    if len(rows) > SHOWN:
        text += (f"<details><summary>{len(rows) - SHOWN + len(counted)} more episode(s)"
                 f"</summary><table>{head_row}{''.join(rows[SHOWN:])}</table>"
                 f"{_counted(counted, crash_header, crash_cell)}</details>")
    return text


def _counted(episodes: list, crash_header: str, crash_cell) -> str:
    """The episodes past the tail's rows, counted by what the crash column says of them."""
    if not episodes:
        return ""
    kinds: dict[str, int] = {}
    for e in episodes:
        verdict = crash_cell(e)
        kind = f"{crash_header}: {verdict}" if verdict else "no crash"
        kinds[kind] = kinds.get(kind, 0) + 1
    listed = "; ".join(f"{n} with {_e(k)}" for k, n in
                       sorted(kinds.items(), key=lambda kv: -kv[1]))
    return (f"<p class='note'>… and {len(episodes)} more, not listed: {listed}. "
            "<code>tracecheck replay --format csv</code> lists every episode.</p>")


def _pictures(result, shown: list, adapter, shield) -> dict[int, str]:
    """Per episode shown (among those ``result`` decoded): the scene of the state in which
    the shield would first have blocked the action (the state before the first blocked step:
    where it would have acted, not the state that action led to), else at its crash; or
    where the environment draws none, its numeric variables over time."""
    from .scene import scene_drawer

    header = result.header
    draw = scene_drawer(getattr(header, "environment", None), adapter=adapter,
                        shield=shield.name,
                        variables=tuple(getattr(header, "variables", None) or ()))
    wanted = {e.episode: max(e.first_infeasible - 1, 0) if e.first_infeasible is not None
              else (e.crash_step or 0) for e in shown}
    return {ep.id: picture(draw, ep, wanted[ep.id]) for ep in result.episodes
            if ep.id in wanted}  # the others were decoded for their viewer pages only


def _write_pages(folder: Path, pages: list, shield: Optional[Shield], adapter=None) -> None:
    """The viewer pages (each: file, its decoded episode, run header, page name), into a new
    folder that replaces ``folder`` once all are written."""
    from ..outputs import atomic_folder, inside, open_new

    with atomic_folder(folder) as tmp:
        for file, episode, header, name in pages:
            data = episode_view(file, episode, header, shield, adapter=adapter)
            with open_new(inside(tmp, name)) as stream:
                stream.write(viewer_page(data).encode("utf-8"))
