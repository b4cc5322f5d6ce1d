"""A search's part of the validation report (``tracecheck report`` of a ``falsify`` run):
ARCH-COMP's figures per optimiser, read back from the episodes' search points; the objective
over the search; and the violations, each with where the search found it, its attribution,
the picture of the state in which it was sealed, and a link to its viewer page. Every text
from the file is escaped: the page is inert (docs/safety.md)."""

from __future__ import annotations

import html
from pathlib import Path

__all__ = ["search_section"]


def _e(text) -> str:
    return html.escape(str(text), quote=True)


def _n(x, empty: str = "–") -> str:
    if x is None:
        return empty
    return f"{x:.4g}" if isinstance(x, float) else str(x)


def search_section(c, shield, adapter, pages: list, page_stem: dict, pages_dir: Path,
                   max_pages: int, salvage: bool = False, shown: int = 8,
                   tail: int = 500) -> str:
    """The search of the checked run ``c`` (its file and header; "" where the run is no
    search): the figures, the objective's plot, and its violations — the first ``shown``
    with their pictures, up to ``tail`` more listed, the rest counted; viewer pages appended
    to ``pages`` (file, episode, header, page name) while there are fewer than
    ``max_pages``."""
    from ..episodes.reader import read_run, search_points
    from ..episodes.summary import space_text
    from ..outputs import safe_name
    from ..search.falsify import recorded_repetitions, summarise
    from .falsify_plot import objective_svg
    from .falsify_text import point_text
    from .pictures import picture
    from .scene import scene_drawer

    header, search = c.header, c.header.search
    if search is None:
        return ""
    points = [(ep, p) for ep, p in search_points(c.file, salvage=salvage) if p is not None]
    name = Path(c.file).name
    title = (f"<h3>{_e(name)}: property {_e(search.property)}, {search.budget} episode(s) "
             f"per search</h3>")
    if not points:
        return title + "<p>The search finished no episode.</p>"
    reps = recorded_repetitions(points)
    order = [search.optimizer] + ([search.baseline] if search.baseline else [])
    order += sorted({r.optimizer for r in reps} - set(order))
    rows = []
    for optimizer in order:
        mine = [r for r in reps if r.optimizer == optimizer]
        if not mine:
            continue
        s = summarise(optimizer, mine)
        first = "none within the budget" if s.first_median is None else (
            f"{_n(s.first_median)} (mean {_n(s.first_mean)}, min {s.first_min}, "
            f"max {s.first_max})")
        kinds = ", ".join(f"{n} {k}" for k, n in sorted(s.attributions.items())) or "–"
        rows.append([optimizer, str(s.repetitions), f"{s.falsified} ({s.rate:.0%})", first,
                     f"{s.violations} of {s.evaluations}", kinds])
    head = ["optimizer", "searches", "falsified", "episodes to the first violation (median)",
            "violating episodes", "attributed"]
    text = [title, "<p class='note'>space: " + _e(space_text(search.space, search.choices))
        + ("; guided by the shield's guard margins" if search.guide else "") + "</p>",
        "<table><tr>" + "".join(f"<th>{_e(h)}</th>" for h in head) + "</tr>"
        + "".join("<tr>" + "".join(f"<td>{_e(x)}</td>" for x in r) + "</tr>" for r in rows)
        + "</table>"]
    values = [(p.optimizer, p.repetition, p.evaluation, p.objective) for _, p in points]
    text.append("<figure class='wide'>" + objective_svg(values, title=search.property)
                + "</figure>")
    violations = [(ep, p) for ep, p in points if p.violated]
    if not violations:
        return "".join(text) + ("<p>No violation within the budget: the search tried these "
                                "points, no more (docs/falsify.md).</p>")
    listed = violations[:shown + tail]
    stem = page_stem.get(str(c.file)) or safe_name(Path(c.file).stem)
    named = {n for *_, n in pages}  # pages the episodes that matter already have
    budget, new = max_pages - len(pages), []
    for ep, _ in listed:
        if f"{stem}_episode_{ep}.html" not in named and budget > 0:
            new.append(ep)
            budget -= 1
    decoded = read_run(c.file, {ep for ep, _ in listed[:shown]} | set(new), salvage=salvage)
    episodes = {ep.id: ep for ep in decoded.episodes}
    draw = scene_drawer(header.environment, adapter=adapter,
                        shield=shield.name if shield is not None else header.shield_name,
                        variables=tuple(header.variables or ()))
    for ep in new:
        if ep in episodes:
            page = f"{stem}_episode_{ep}.html"
            pages.append((c.file, episodes[ep], decoded.header, page))
            named.add(page)
    body = []
    for i, (ep, p) in enumerate(listed):
        pic = ""
        if i < shown and ep in episodes:
            pic = picture(draw, episodes[ep], _sealed(episodes[ep], p))
        why = "not attributed" if p.attribution is None else (
            p.attribution + (f" at step {p.attribution_step}" if p.attribution_step is not None
                             else "") + (f": {p.attribution_detail}"
                                         if p.attribution_detail else ""))
        page = f"{stem}_episode_{ep}.html"
        link = f"<a href='{_e(pages_dir.name + '/' + page)}'>open</a>" if page in named \
            else "(not rendered)"
        body.append(f"<tr><td>{ep}</td><td>{_e(p.optimizer)}, search {p.repetition}, "
                    f"evaluation {p.evaluation + 1}</td><td>{_e(point_text(p.parameters))}</td>"
                    f"<td>{_e(_n(p.objective))}</td><td>{_e(why)}</td>"
                    f"<td class='pic'>{pic}</td><td>{link}</td></tr>")
    head_row = "<tr>" + "".join(f"<th>{h}</th>" for h in (
        "episode", "found by", "search point", "objective", "why (attribution)",
        "picture", "viewer")) + "</tr>"
    text.append("<p class='note'>The violations, in the order the search found them. The "
                "picture shows the state in which the attributed step's action was taken "
                "(else the failure).</p>")
    text.append(f"<table>{head_row}{''.join(body[:shown])}</table>")
    if len(body) > shown:
        rest = len(violations) - len(listed)
        text.append(f"<details><summary>{len(violations) - shown} more violation(s)</summary>"
                    f"<table>{head_row}{''.join(body[shown:])}</table>"
                    + (f"<p class='note'>… and {rest} more, not listed: <code>tracecheck "
                       f"falsify</code>'s JSON lists every one.</p>" if rest else "")
                    + "</details>")
    return "".join(text)


def _sealed(episode, point) -> int:
    """The step whose state the picture shows: the state in which the attributed step's
    action was taken, else the first crash, else the last state."""
    if point.attribution_step is not None:
        return max(0, point.attribution_step - 1)
    return next((s.step for s in episode.steps if s.crashed), len(episode.steps) - 1)

