"""Replay and diff reports for people: rich text for the terminal, Markdown for files."""

from __future__ import annotations

from rich.console import Console
from rich.table import Table
from rich.text import Text

from ..checking.diffing import ChangedStep, DiffReport
from ..checking.replaying import (MISMATCH, NEW_CRASH, NOT_PREVENTED, PREVENTED, EpisodeReplay,
                               ReplayReport)
from .emit import Report
from .tables import TableData, fitted, markdown, md_text

#: above this many rows, a table of episodes is printed as aligned lines (rich's layout of
#: 10^4 rows takes seconds)
PLAIN_ROWS = 200

__all__ = ["ReplayOutput", "DiffOutput", "crash_column", "literal_row", "continuous_cell",
           "action_call", "NOT_A_FLOAT"]


def literal_row(table: Table, cells) -> None:
    """Add a row whose cells are shown as they are: a file named ``run[bold].mcap`` keeps its
    brackets (a plain string in a rich table is read as markup)."""
    table.add_row(*(Text(str(cell)) for cell in cells))


def _short(sha: str) -> str:
    return sha[:12]


def _steps(values: list[int], limit: int = 6) -> str:
    text = ", ".join(str(v) for v in values[:limit])
    return text + (f", … (+{len(values) - limit})" if len(values) > limit else "")


def abbreviations(actions) -> dict[str, str]:
    """A short, unique code per action name for tables that must fit 80 columns: the
    initials of its last word (LANE_LEFT → L, Move_Down → D), longer where two collide."""
    names = sorted(set(actions))
    words = {a: a.replace("-", "_").split("_")[-1] or a for a in names}
    for size in range(1, max((len(w) for w in words.values()), default=0) + 1):
        codes = {a: words[a][:size].upper() for a in names}
        if len(set(codes.values())) == len(codes):
            return codes
    return {a: a for a in names}  # last words alike: the names themselves


#: the "other" column's labels: in full (CSV, Markdown), and short for a terminal
OTHER_LABELS = ("deadlock", "postcondition", "invariant")
SHORT_OTHER = ("deadlock", "post", "inv")


def _row(e: EpisodeReplay, crash_cell, short=None) -> list[str]:
    """One episode's cells; with ``short`` (an action's abbreviation) the terminal's: the
    "other" column's labels short and its steps cut to three, else every step in full."""
    labels, limit = (SHORT_OTHER, 3) if short is not None else (OTHER_LABELS, None)
    short = short or (lambda a: a)
    first = "" if e.first_infeasible is None else f"{e.first_infeasible} {short(e.action or '')}"
    other = []
    for label, steps in zip(labels, (e.deadlock_states, e.postcondition_violations,
                                     e.invariant_violations)):
        if steps:
            other.append(f"{label} {_steps(steps, limit or len(steps))}")
    return [
        e.file.rsplit("/", 1)[-1], str(e.episode), str(e.steps), first,
        " ".join(short(a) for a in e.enabled or []), short(e.alternative or ""),
        str(e.infeasible_steps), "" if e.crash_step is None else str(e.crash_step),
        crash_cell(e), "; ".join(other),
    ]


#: the crash column without re-simulation: a fact of the recording, not a verdict
AFTER_BLOCK = "crash after a blocked step"
RESIMULATED = "re-simulated"
AFTER_BLOCK_LEGEND = ("after block: the crash came at or after the first blocked step (whether "
                      "blocking it prevents the crash, --resimulate finds out)")
RESIMULATED_LEGEND = ("re-simulated: the episode run again from its seed, the agent under the "
                      "shield from the first blocked step on: prevented, not prevented, new "
                      "crash, no crash, did not reproduce (the recording, up to that step: "
                      "outcome unknown), never blocked (a crash the shield would not have "
                      "changed)")


def crash_column(r: ReplayReport):
    """(header, short header, cell(e)) of the episode table's crash column: with a
    re-simulation what it found (the same words as the lines above the table), else whether
    the recorded crash came at or after the first blocked step — which is not "prevented":
    only re-simulation says whether blocking that step saves the episode."""
    outcomes = r.resimulated()
    if outcomes is not None:
        return RESIMULATED, RESIMULATED, lambda e: outcomes[(e.file, e.episode)]
    return AFTER_BLOCK, "after block", lambda e: (
        ("yes" if e.crash_after_infeasible else "no") if e.crashed else "")


HEADERS = ["file", "episode", "steps", "first infeasible", "allowed there", "shielded",
           "infeasible", "crash", AFTER_BLOCK, "other"]
#: the same columns in a terminal: short enough for 80 columns, explained under the table
SHORT_HEADERS = ["file", "ep.", "steps", "first", "allowed", "instead", "blocked", "crash",
                 "after block", "other"]


def _with_crash_header(headers: list[str], header: str) -> list[str]:
    """``headers`` (:data:`HEADERS` or :data:`SHORT_HEADERS`) with ``header`` as the crash
    column's (see :func:`crash_column`)."""
    at = HEADERS.index(AFTER_BLOCK)
    return headers[:at] + [header] + headers[at + 1:]


def _summary_lines(r: ReplayReport) -> list[str]:
    rate = f"{r.steps / r.elapsed_s:,.0f} steps/s" if r.elapsed_s else ""
    return [
        f"Replay against shield {r.shield['name']} (sha256 {_short(r.shield['sha256'])}): "
        f"{r.episodes} episode(s), {r.steps} step(s) in {r.elapsed_s:.3f} s ({rate})",
        f"infeasible: {r.infeasible_steps} step(s) in {r.infeasible_episodes} of {r.episodes} "
        f"episode(s); {r.feasible_episodes} episode(s) fully feasible",
        f"crashes: {r.crashes}, of which {r.crashes_after_infeasible} at or after the first "
        f"infeasible step (the shield would have blocked the way there)",
        f"deadlock states: {r.deadlock_states}; postcondition violations: "
        f"{r.postcondition_violations}; invariant violations: {r.invariant_violations}",
    ]


def _resim_lines(r: ReplayReport) -> list[str]:
    s = r.resimulation
    if s is None:
        return []
    lines = [f"re-simulated {s['resimulated']} infeasible episode(s) under {r.shield['name']}: "
             f"{s['crashes_prevented']} crash(es) prevented, {s['crashes_not_prevented']} not "
             f"prevented, {s['new_crashes']} new crash(es), {s['no_crash_either_way']} without "
             f"a crash either way, {s['mismatches']} did not reproduce the recording"
             + (f", {s['without_seed']} without a seed (imported)" if s["without_seed"] else "")]
    if s["mismatches"]:
        lines.append(f"{s['mismatches']} of {s['resimulated']} re-simulated episode(s) did not "
                     "reproduce the recording up to the first blocked step: their outcome is "
                     "unknown (--fail-on mismatch exits 1)")
    for e in s["per_episode"]:
        if e["outcome"] in (PREVENTED, NOT_PREVENTED, NEW_CRASH, MISMATCH):
            crash = (f", crash at step {e['new_crash_step']}"
                     if e["new_crash_step"] is not None else "")
            detail = f" ({e['detail']})" if e["detail"] else ""
            lines.append(f"  episode {e['episode']} (seed {e['seed']}): {e['outcome']}{crash}"
                         f"{detail}")
    return lines


def _ltl_lines(r: ReplayReport, rows: int) -> list[str]:
    lines = []
    for e in r.ltl:
        head = f"LTL {e['name']}: {e['formula']}"
        held = f"{e['satisfied']} of {e['episodes']} episode(s) satisfy it"
        if not e["violations"]:
            lines.append(f"{head} — {held}")
            continue
        shown = []
        for v in e["violations"][:rows]:
            where = f"episode {v['episode']}"
            if len(r.files) > 1:
                where = f"{v['file'].rsplit('/', 1)[-1]} {where}"
            if v["first_step"] is not None:
                where += f" (step {v['first_step']})"
            shown.append(where)
        more = len(e["violations"]) - len(shown)
        lines.append(f"{head} — {held}; violated in {', '.join(shown)}"
                     + (f" and {more} more" if more > 0 else ""))
    return lines


def _number(x: float) -> str:
    return f"{x:.6g}"


def action_call(action: str, parameters: dict) -> str:
    """A continuous action with its recorded values: ``ACCELERATE(a=1.5)``."""
    values = ", ".join(f"{p}={_number(v)}" for p, v in parameters.items())
    return f"{action}({values})"


def continuous_cell(e: EpisodeReplay) -> str:
    """A continuous action at the first infeasible step, its values, what the shield allowed
    and how far from it: ``ACCELERATE(a=1.5): a ∈ [-4.0, 0.3), 1.2 from the nearest
    allowed value`` ("" for an episode without one; a set the solver decides is said as
    one, with the region it was searched in)."""
    if e.parameters is None:
        return ""
    text = action_call(e.action, e.parameters) + (f": {e.allowed}" if e.allowed else "")
    return text + (f", {_number(e.margin)} from the nearest allowed value"
                   if e.margin is not None else f", {e.margin_note}")


#: what an interval's end followed by ``…`` means (said under the lines that show one)
NOT_A_FLOAT = ("an end followed by … is not exactly a float: the float nearest it is shown "
               "(the allowed set is computed exactly, over the reals)")


def _where(files: list[str], file: str, episode: int) -> str:
    """``episode 3``, or with the file's name where a report has several files."""
    return f"{file.rsplit('/', 1)[-1]} episode {episode}" if len(files) > 1 else \
        f"episode {episode}"


def _with_legend(lines: list[str], allowed_texts) -> list[str]:
    """``lines``, then :data:`NOT_A_FLOAT` where one of ``allowed_texts`` has such an end."""
    return lines + ([f"  ({NOT_A_FLOAT})"] if any("…" in (t or "") for t in allowed_texts)
                    else [])


def _continuous_lines(r: ReplayReport, episodes) -> list[str]:
    """For each episode in ``episodes`` whose first infeasible step is a continuous action:
    that action (:func:`continuous_cell`); nothing for a run of discrete actions."""
    shown = [e for e in episodes if e.parameters is not None]
    if not shown:
        return []
    lines = ["continuous actions at the first infeasible step — the recorded values, those the "
             "shield allowed there and how far from them (Euclidean, in the parameters' "
             "units):"]
    for e in shown:
        largest = ""
        if e.max_margin is not None and e.max_margin != e.margin:
            largest = f" (in the episode up to {_number(e.max_margin)})"
        lines.append(f"  {_where(r.files, e.file, e.episode)}, step {e.first_infeasible}: "
                     f"{continuous_cell(e)}{largest}")
    return _with_legend(lines, (e.allowed for e in shown))


def _replay_text(console: Console, r: ReplayReport, rows: int) -> None:
    for i, line in enumerate(_summary_lines(r) + _resim_lines(r) + _ltl_lines(r, rows)):
        console.print(Text(line, style="bold" if i == 0 else ""), highlight=False,
                      soft_wrap=False)  # wrapped between words; names printed as they are
    matters = [e for e in r.per_episode if e.matters]
    if not matters:
        console.print("every step of every episode is feasible; nothing else found")
        return
    one_file = len(r.files) == 1
    names = {a for e in matters for a in [e.action, e.alternative, *(e.enabled or [])] if a}
    codes = abbreviations(names)
    table = Table(title="episodes that matter", box=None, show_lines=False, padding=(0, 1))
    _, short_header, crash_cell = crash_column(r)
    headers = _with_crash_header(SHORT_HEADERS, short_header)
    shown = [_row(e, crash_cell, lambda a: codes.get(a, a)) for e in matters[:rows]]
    if len(shown) > PLAIN_ROWS:  # --all of a campaign: aligned lines, not rich's layout
        cut = 1 if one_file else 0
        console.file.write("episodes that matter\n" + "\n".join(fitted(TableData.of(
            headers[cut:], [[str(c) for c in row[cut:]] for row in shown]), 10 ** 6)) + "\n")
        shown = []
    # "other" wraps between words only: never narrower than its longest word
    longest = max((len(w) for row in shown for w in row[-1].split()), default=5)
    for header in headers[1:] if one_file else headers:
        if header == "file":
            table.add_column(header, no_wrap=True, overflow="ellipsis", max_width=14)
        elif header == "other":
            table.add_column(header, overflow="fold", min_width=max(5, longest))
        else:
            table.add_column(header, no_wrap=True, overflow="fold")
    for row in shown:
        literal_row(table, row[1:] if one_file else row)
    if shown:
        console.print(table)
    for line in _continuous_lines(r, matters[:rows]):
        console.print(Text(line), highlight=False, soft_wrap=False)
    legend = ", ".join(f"{c} = {a}" for a, c in sorted(codes.items(), key=lambda x: x[1])
                       if c != a)
    console.print("first: the first step the shield would have blocked, and its action; "
                  "allowed: what the shield allowed there; instead: what a shielded agent "
                  "would have done; blocked: steps it would have blocked; other: the steps "
                  "with a deadlock, a postcondition (post) or an invariant (inv) violation; "
                  + (RESIMULATED_LEGEND if short_header == RESIMULATED else AFTER_BLOCK_LEGEND)
                  + (f"; actions: {legend}" if legend else ""), highlight=False,
                  soft_wrap=False)
    if len(matters) > rows:
        console.print(f"… {len(matters) - rows} more episode(s): --all lists them, --json "
                      "gives everything")


def _replay_table(r: ReplayReport, episodes=None) -> TableData:
    """The episode table with full names: ``episodes`` (default: every episode replayed);
    then a column ``LTL NAME: FORMULA`` per LTL formula checked (its text too: CSV has no
    other place for it): holds, violated, or violated at step k (the first step where ``G
    f`` fails)."""
    chosen = r.per_episode if episodes is None else episodes
    failed = [{(v["file"], v["episode"]): v["first_step"] for v in e["violations"]}
              for e in r.ltl]

    def ltl_cell(e: EpisodeReplay, violations: dict) -> str:
        if (e.file, e.episode) not in violations:
            return "holds"
        step = violations[(e.file, e.episode)]
        return "violated" if step is None else f"violated at step {step}"

    header, _, crash_cell = crash_column(r)
    continuous = any(e.parameters is not None for e in r.per_episode)
    return TableData.of(_with_crash_header(HEADERS, header)
                        + (CONTINUOUS_HEADERS if continuous else [])
                        + [f"LTL {e['name']}: {e['formula']}" for e in r.ltl],
                        (_row(e, crash_cell) + (_continuous_row(e) if continuous else [])
                         + [ltl_cell(e, v) for v in failed] for e in chosen))


#: the columns of continuous actions, in a table of a run that has some
CONTINUOUS_HEADERS = ["parameters", "allowed values", "margin", "largest margin"]


def _continuous_row(e: EpisodeReplay) -> list:
    """The cells under :data:`CONTINUOUS_HEADERS`: the first infeasible step's values, what
    the shield allowed, the margin (or why there is none), the episode's largest."""
    if e.parameters is None:
        return ["", "", "", e.max_margin]
    values = " ".join(f"{p}={v!r}" for p, v in e.parameters.items())
    return [values, e.allowed or "", e.margin if e.margin is not None else e.margin_note,
            e.max_margin]


def _replay_markdown(r: ReplayReport, rows: int) -> str:
    lines = [f"# Replay: shield `{r.shield['name']}`", ""]
    lines += [f"- {md_text(line, cell=False)}"
              for line in _summary_lines(r) + _resim_lines(r) + _ltl_lines(r, rows)]
    matters = [e for e in r.per_episode if e.matters]
    if matters:
        lines += ["", markdown(_replay_table(r, matters[:rows]))]
        if len(matters) > rows:
            lines.append(f"\n{len(matters) - rows} more episode(s): --all lists them, the "
                         "JSON report has everything.")
    return "\n".join(lines)


def _diff_text(console: Console, d: DiffReport, rows: int) -> None:
    # a Text, not markup: shield and file names are printed as they are, brackets and all
    console.print(Text(f"Shield {d.shield['name']} ({_short(d.shield['sha256'])}) against "
                       f"{d.against['name']} ({_short(d.against['sha256'])}): {d.episodes} "
                       f"episode(s), {d.steps} step(s), {d.states} state(s)", style="bold"),
                  highlight=False, soft_wrap=False)
    console.print(Text(f"changed steps: {d.changed_steps} (newly blocked {d.newly_blocked}, "
                       f"newly allowed {d.newly_allowed}: by {d.shield['name']}, where "
                       f"{d.against['name']} decided otherwise); states whose enabled set "
                       f"differs: {d.enabled_set_changes}"), highlight=False, soft_wrap=False)
    console.print(f"episodes whose first infeasible step moved: {d.episodes_changed} "
                  f"({d.crashes_in_changed_episodes} of them crashed)", highlight=False,
                  soft_wrap=False)
    if not d.changes:
        return
    names = {a for c in d.changes[:rows] for a in [c.action, *c.enabled_shield,
                                                    *c.enabled_against]}
    codes = abbreviations(names)
    one_file = len(d.files) == 1
    table = Table(title="changed steps", box=None, padding=(0, 1))
    for header in (["file"] if not one_file else []) + ["ep.", "step", "action",
                                                       d.shield["name"], d.against["name"],
                                                       "enabled by " + d.shield["name"],
                                                       "enabled by " + d.against["name"]]:
        if header == "file":
            table.add_column(header, no_wrap=True, overflow="ellipsis", max_width=14)
        else:
            table.add_column(Text(header), no_wrap=not header.startswith("enabled"))
    for c in d.changes[:rows]:
        row = _diff_row(c, lambda a: codes.get(a, a))
        literal_row(table, row[1:] if one_file else row)
    console.print(table)
    legend = ", ".join(f"{c} = {a}" for a, c in sorted(codes.items(), key=lambda x: x[1])
                       if c != a)
    if legend:
        console.print(f"actions: {legend}", highlight=False, soft_wrap=False)
    for line in _diff_continuous_lines(d, d.changes[:rows]):
        console.print(Text(line), highlight=False, soft_wrap=False)
    if len(d.changes) > rows or d.changes_left_out:
        more = max(len(d.changes) - rows, 0) + d.changes_left_out
        console.print(f"… {more} more changed step(s): --format csv or json lists " + (
                          f"the first {d.listed} (--all: every one)" if d.changes_left_out
                          else "them all") + (
                          f" (with the allowed sets of the first {d.details} of continuous "
                          f"actions; {d.details_left_out} more have their values only)"
                          if d.details_left_out else ""), highlight=False, soft_wrap=False)


def _diff_row(c, short=lambda a: a) -> list[str]:
    return [c.file.rsplit("/", 1)[-1], str(c.episode), str(c.step), short(c.action),
            "allowed" if c.feasible_under_shield else "blocked",
            "allowed" if c.feasible_under_against else "blocked",
            " ".join(short(a) for a in c.enabled_shield),
            " ".join(short(a) for a in c.enabled_against)]


def _allowed_moved(c: ChangedStep, d: DiffReport) -> str:
    """What the old shield allowed → what the new one allows, and how it moved: ``a ∈
    [-4.0, 0.5) → [-4.0, 1.25): upper end +0.75`` (a set not computed: the shield's name
    and why)."""
    if c.allowed is None:
        return f"allowed sets left out (only the first {d.details} are computed)"
    old, new = c.allowed.against, c.allowed.shield
    if old.text is not None and new.text is not None and len(c.parameters) == 1 and \
            " ∈ " in old.text and " ∈ " in new.text:  # both intervals: the name said once
        text = f"{old.text} → {new.text.partition(' ∈ ')[2]}"
    else:
        text = " → ".join(v.text if v.text is not None else f"{name}: {v.note}"
                          for v, name in ((old, d.against["name"]), (new, d.shield["name"])))
    return text + (f": {c.allowed.moved}" if c.allowed.moved else "")


def _diff_continuous_lines(d: DiffReport, changes) -> list[str]:
    """For each changed step in ``changes`` of a continuous action: its recorded values, the
    values each shield allowed and how they moved (nothing for discrete actions)."""
    shown = [c for c in changes if c.parameters is not None]
    if not shown:
        return []
    lines = [f"continuous actions at the changed steps — the recorded values, then what "
             f"{d.against['name']} allowed in the state before → what {d.shield['name']} "
             "allows, and how it moved:"]
    for c in shown:
        verdict = "newly allowed" if c.feasible_under_shield else "newly blocked"
        lines.append(f"  {_where(d.files, c.file, c.episode)}, step {c.step}: "
                     f"{action_call(c.action, c.parameters)} {verdict}: {_allowed_moved(c, d)}")
    return _with_legend(lines, (v.text for c in shown if c.allowed is not None
                                for v in (c.allowed.shield, c.allowed.against)))


def _diff_continuous_headers(d: DiffReport) -> list[str]:
    """The columns of continuous actions, in a diff table of a run that has some."""
    return ["parameters", f"allowed by {d.against['name']}", f"allowed by {d.shield['name']}",
            "moved"]


def _diff_continuous_row(c: ChangedStep, d: DiffReport) -> list:
    """The cells under :func:`_diff_continuous_headers`: the recorded values, what each
    shield allowed (or why that is not known), how it moved."""
    if c.parameters is None:
        return ["", "", "", ""]
    values = " ".join(f"{p}={v!r}" for p, v in c.parameters.items())
    if c.allowed is None:
        left_out = f"left out (only the first {d.details} are computed)"
        return [values, left_out, left_out, ""]
    old, new = c.allowed.against, c.allowed.shield
    return [values, old.text if old.text is not None else old.note,
            new.text if new.text is not None else new.note, c.allowed.moved or ""]


def _diff_table(d: DiffReport) -> TableData:
    """Every changed step, with full action names; for continuous actions also their values,
    the values each shield allowed and how they moved."""
    a, b = d.shield["name"], d.against["name"]
    continuous = any(c.parameters is not None for c in d.changes)
    return TableData.of(["file", "episode", "step", "action", a, b, f"enabled by {a}",
                         f"enabled by {b}"] + (_diff_continuous_headers(d) if continuous else []),
                        (_diff_row(c) + (_diff_continuous_row(c, d) if continuous else [])
                         for c in d.changes))


class ReplayOutput(Report):
    """``replay``'s report in every format (``rows``: the episodes listed for people)."""

    def __init__(self, report: ReplayReport, rows: int) -> None:
        self.report, self.rows = report, rows

    def data(self):
        return self.report.json_parts()

    def table(self) -> TableData:
        return _replay_table(self.report)

    def markdown(self) -> str:
        return _replay_markdown(self.report, self.rows)

    def text(self, console) -> None:
        _replay_text(console, self.report, self.rows)


class DiffOutput(Report):
    """``diff``'s report on recorded states in every format."""

    def __init__(self, report: DiffReport, rows: int) -> None:
        self.report, self.rows = report, rows

    def data(self):
        return self.report.to_json()

    def table(self) -> TableData:
        return _diff_table(self.report)

    def text(self, console) -> None:
        _diff_text(console, self.report, self.rows)
