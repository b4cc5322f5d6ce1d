"""One episode as a self-contained HTML page (inline SVG, CSS and JS; nothing from the web).

For any environment: a time-series panel with one chart per numeric variable of the B state
(a function into numbers, such as ``VehiclesVx``, is one chart with a line per element), the
steps the chosen shield would have blocked, the live shield's interventions and the crash
marked; a timeline; back, forward and play (buttons and arrow keys); per step the action
taken, what the live shield allowed, what the chosen shield allows, the agent's action values,
the reward and the B state (numbers rounded for people, full precision on hover and in a copy
button).

For continuous actions (an operation with REAL parameters), each parameter has a chart of
its own, first: the agent's proposal (dashed), the executed value, and the values the live
shield allowed in the state before as a shaded band per step (one per interval; an unbounded
end reaches the chart's edge; a step where nothing was allowed marked red); the step panel
says what was proposed, executed and allowed, and how far the shield moved the proposal.

Above them, the step's scene (:mod:`tracecheck.render.scene`) where the environment has one:
what its adapter draws with its ``scene`` hook (a road with the zones a shield tests, a grid
world's map, …), with a caption saying how to read it. An environment without a scene gets no empty canvas.
"""

from __future__ import annotations

import html
import math
import re
from dataclasses import asdict
from pathlib import Path
from typing import Optional, Sequence

from ..b.linear import real_parameters
from ..b.values import Elem, SymbolicSet, format_value, sort_key
from ..episodes.columns import RunColumns, episode_columns
from ..episodes.model import Episode
from ..episodes.reader import find_episode, read_run
from ..checking.shield import Shield
from ..errors import InputError
from ..jsontext import plain, script_json
from .scene import no_scene_caption, scene_drawer, shape_json, css
from .tables import is_number

__all__ = ["render_episode", "viewer_page", "episode_data", "episode_view", "short_value",
           "numeric_series", "action_series"]

_TEMPLATE = (Path(__file__).with_name("viewer.html")).read_text(encoding="utf-8")
def _round(x: float) -> str:
    if not math.isfinite(x):
        return str(x)
    if 1e4 <= abs(x) < 1e15:
        return f"{x:.0f}"
    text = f"{x:.4g}"
    return text if any(c in text for c in ".en") else text + ".0"


def short_value(value) -> str:
    """``value`` in B notation with every real rounded to 4 significant digits, for people
    (``52.2``, not ``52.20011520385742``); :func:`format_value` gives the exact text.

    >>> short_value(52.20011520385742)
    '52.2'
    """
    if isinstance(value, float):
        return _round(value)
    if isinstance(value, tuple):
        parts, left = [short_value(value[1])], value[0]
        while isinstance(left, tuple):
            parts.append(short_value(left[1]))
            left = left[0]
        parts.append(short_value(left))
        return "(" + "↦".join(reversed(parts)) + ")"
    if isinstance(value, frozenset) and not isinstance(value, SymbolicSet) and value:
        return "{" + ",".join(short_value(v) for v in sorted(value, key=sort_key)) + "}"
    return format_value(value)


def numeric_series(states: Sequence[dict]) -> list[dict]:
    """One entry per numeric variable of ``states`` (each ``{"name", "lines": [{"label",
    "values"}]}``, a value per state, None where the state has none): a number is one line, a
    function into numbers one line per element of its domain (``VehiclesVx(EgoVehicle)``)."""
    names = list(dict.fromkeys(k for s in states for k in s))
    out = []
    for name in names:
        values = [s.get(name) for s in states]
        given = [v for v in values if v is not None]
        if given and all(is_number(v) for v in given):
            out.append({"name": name, "lines": [{"label": name, "values": [
                float(v) if v is not None else None for v in values]}]})
            continue
        maps = [getattr(v, "map", None) for v in given]
        if not given or any(m is None for m in maps) or not all(
                is_number(x) for m in maps for x in m.values()):
            continue
        keys = list(dict.fromkeys(k for m in maps for k in m))
        if not keys:
            continue
        lines = [{"label": f"{name}({k if isinstance(k, Elem) else format_value(k)})",
                  "values": [float(getattr(v, "map", {}).get(k)) if v is not None and
                             getattr(v, "map", {}).get(k) is not None else None
                             for v in values]} for k in keys]
        out.append({"name": name, "lines": lines})
    return out


def _scenes(ep, draw) -> tuple[Optional[dict], list]:
    """(the scene common to the episode: view, background, caption and a table of distinct
    shapes; None when there is no picture), per step the indices of its shapes."""
    table: dict[str, int] = {}
    shapes, per_step, first = [], [], None
    for s in ep.steps:
        scene = draw(s)
        if scene is None:
            per_step.append(None)
            continue
        first = first or scene
        indices = []
        for shape in scene.shapes:
            data = shape_json(shape)
            key = repr(sorted(data.items()))
            if key not in table:
                table[key] = len(shapes)
                shapes.append(data)
            indices.append(table[key])
        per_step.append({"shapes": indices, "view": list(scene.view)})
    if first is None:
        return None, per_step
    return {"shapes": shapes, "background": css(first.background), "caption": first.caption,
            "scale": first.scale}, per_step


def episode_data(run: str | Path, episode: int, shield: Optional[Shield] = None,
                 ltl: Sequence[tuple] = (), adapter=None, salvage: bool = False) -> dict:
    """Everything the viewer shows of episode ``episode`` of ``run``, read from the file
    (see :func:`episode_view`; ``salvage``: as :func:`~tracecheck.episodes.reader.read_run`)."""
    result = read_run(run, {episode}, salvage=salvage)
    ep = find_episode(run, result, episode, salvage)
    cols = episode_columns([ep], _action_names(ep, result.header)) if ltl else None
    return episode_view(run, ep, result.header, shield, ltl, cols, adapter)


def _action_names(ep: Episode, header) -> list[str]:
    """The run's action names: its header's, else those the episode takes."""
    return list(header.actions) if header is not None and header.actions \
        else sorted({s.action for s in ep.steps if s.action})


def episode_view(run: str | Path, ep: Episode, header, shield: Optional[Shield] = None,
                 ltl: Sequence[tuple] = (), cols: Optional[RunColumns] = None,
                 adapter=None) -> dict:
    """Everything the viewer shows of the decoded episode ``ep`` of ``run`` (``header``: its
    run header), as JSON-ready data (``ltl``: (name, text, formula) of LTL formulas over
    ``shield``'s machine, each marked where the episode first violates it, checked on
    ``cols``, the run's columns, which ``ltl`` needs; ``adapter``: the environment's adapter
    (``--env``), whose ``scene`` hook draws the steps; without one, the installed adapter of
    the run's environment, if any)."""
    if ltl and cols is None:
        raise ValueError("LTL marks are checked on the run's columns: give cols")
    machine = shield.machine if shield is not None else None
    draw = scene_drawer(getattr(header, "environment", None), adapter=adapter,
                        shield=shield.name if shield is not None else None,
                        variables=tuple(getattr(header, "variables", None) or ()))
    scene, per_step = _scenes(ep, draw)
    steps, blocked, interventions = [], [], []
    for k, s in enumerate(ep.steps):
        enabled = sorted(machine.enabled(s.state)) if machine is not None else None
        if k and machine is not None and not _allowed_step(
                machine, ep.steps[k - 1], s, steps[-1]["shield_allows"],
                f"{run}, episode {ep.id}, step {s.step}"):
            blocked.append(s.step)
        if (s.preferred_action is not None and s.action is not None
                and s.preferred_action != s.action) or _moved(s):
            interventions.append(s.step)
        steps.append({
            "step": s.step, "time": s.time, "action": s.action, "reward": s.reward,
            "crashed": s.crashed, "live_allowed": list(s.allowed_actions)
            if s.allowed_actions is not None else None,
            "shield_allows": enabled, "values": dict(s.action_values or {}) or None,
            "preferred": s.preferred_action, "scene": per_step[k],
            "state": [[name, short_value(v), format_value(v)] for name, v in s.state.items()],
            **_continuous_step(s),
        })
    crash = next((s["step"] for s in steps if s["crashed"]), None)
    actions = action_series(ep, shield)
    series = actions + numeric_series([s.state for s in ep.steps])
    rewards = [float(s.reward) for s in ep.steps]
    if not any(line["values"] == rewards for entry in series for line in entry["lines"]):
        series.append({"name": "reward", "lines": [{"label": "reward (of the step)",
                                                    "values": rewards}]})
    return {
        **({"parameters": [a["parameter"] for a in actions]} if actions else {}),
        "file": str(run), "episode": ep.id, "seed": ep.seed, "origin": ep.origin,
        "config": plain(dict(ep.config)) if ep.config else None,
        "reset_options": plain(dict(ep.reset_options)) if ep.reset_options else None,
        "search": plain(asdict(ep.search)) if ep.search is not None else None,
        "environment": header.environment if header is not None else None,
        "actions": _action_names(ep, header),
        "scene": scene, "no_scene_caption": no_scene_caption(
            getattr(header, "environment", None), adapter,
            tuple(getattr(header, "variables", None) or ())) if scene is None else None,
        "shield": shield.name if shield is not None else None,
        "first_infeasible": blocked[0] if blocked else None, "blocked": blocked,
        "interventions": interventions, "crash_step": crash,
        "ltl": _ltl_marks(cols, ep.id, shield, ltl), "series": series,
        "end": {"steps": ep.end.steps, "reason": ep.end.reason,
                "total_reward": ep.end.total_reward},
        "steps": steps,
    }


def _allowed_step(machine, before, step, enabled: list, where: str) -> bool:
    """Whether the shield allowed the step's action in the state before: a continuous one
    (an operation with REAL parameters) by its guard with the recorded values, as replay
    decides it."""
    op = machine.operations.get(step.action) if step.action is not None else None
    if op is None or not real_parameters(op):
        return step.action in enabled
    missing = [p for p in op.params if p not in (step.parameters or {})]
    if missing:
        raise InputError(f"{where}: the recorded action {step.action} has no value for its "
                         f"parameter {missing[0]}, which the shield's {step.action} takes",
                         hint="a continuous action is judged with the values recorded with it")
    return machine.allows(step.action, before.state, step.parameters)


def _moved(step) -> bool:
    """Whether the live shield changed a continuous action's proposal at ``step``."""
    executed, proposed = step.parameters, step.proposal
    return bool(executed and proposed) and any(
        name in proposed and proposed[name] != value for name, value in executed.items())


def _bands(intervals) -> list:
    """Intervals as JSON: ``[[low, high], …]``, None for an unbounded end."""
    return [[None if lo is None else float(lo), None if hi is None else float(hi)]
            for lo, hi in intervals]


def _continuous_step(step) -> dict:
    """The step panel's fields of a continuous action (none for a discrete step)."""
    if step.parameters is None:
        return {}
    return {"parameters": dict(step.parameters), "proposal": dict(step.proposal or {}) or None,
            "distance": step.projection_distance, "deadlock": bool(step.deadlock),
            "allowed": None if step.allowed_intervals is None else {
                name: _bands(found) for name, found in step.allowed_intervals.items()}}


def _per_step(ep: Episode, field: str, name: str) -> list:
    """Per step, the value of parameter ``name`` in the step's ``field`` (None if none)."""
    found = [(getattr(s, field) or {}).get(name) for s in ep.steps]
    return [None if v is None else float(v) for v in found]


def action_series(ep: Episode, shield: Optional[Shield] = None) -> list[dict]:
    """One chart per parameter of the episode's continuous actions (none for a discrete
    episode), as :func:`numeric_series` gives them, with ``bands``: per step the allowed
    intervals of the parameter the live shield recorded (``[[low, high], …]``, None for an
    unbounded end; ``[]``: nothing allowed; None where none were recorded), and with a
    ``shield`` (``render --shield S``) ``shield_bands``: what S's guard allows at each step,
    in the state before it (None where S's allowed set is the solver's, not intervals). Its
    lines: the agent's proposal (dashed) and the executed value."""
    owner: dict[str, str] = {}
    for s in ep.steps:
        for name in s.parameters or ():
            owner.setdefault(name, s.action)
    out = []
    for name, op in owner.items():
        bands = [None if s.allowed_intervals is None or name not in s.allowed_intervals
                 else _bands(s.allowed_intervals[name]) for s in ep.steps]
        entry = {"name": f"{op}({name})", "parameter": name, "kind": "action",
                 "lines": [{"label": f"{name} proposed", "values": _per_step(ep, "proposal", name),
                            "dashed": True},
                           {"label": f"{name} executed", "values": _per_step(ep, "parameters", name)}],
                 "bands": bands}
        if shield is not None and op in shield.machine.operations and real_parameters(
                shield.machine.operations[op]):
            bands_of_s = [None] + [_shield_band(shield.machine, op, name, before.state)
                                   for before in ep.steps[:-1]]
            if any(b is not None for b in bands_of_s):  # a set the solver decides: none
                entry["shield_bands"] = bands_of_s
        out.append(entry)
    return out


def _shield_band(machine, op: str, name: str, state) -> Optional[list]:
    """What ``machine``'s guard of ``op`` allows of parameter ``name`` in ``state``, as
    intervals; None where that is no set of intervals (the solver's set, several parameters
    not separable) or the guard cannot be judged there (nothing is drawn)."""
    from ..errors import TracecheckError
    from ..live.continuous import interval_pairs

    try:
        bands = machine.allowed(op, state).bands()
    except (TracecheckError, AttributeError):
        return None
    if bands is None or name not in bands:
        return None
    return _bands(interval_pairs(bands[name]))


def _ltl_marks(cols: Optional[RunColumns], episode: int, shield: Optional[Shield],
               ltl: Sequence[tuple]) -> list:
    if not ltl:
        return []
    from ..checking.crashflag import flagged, with_crash_flag
    from ..checking.ltl import check_ltl

    cols, machine = with_crash_flag(cols), flagged(shield.machine)
    marks = []
    for name, text, formula in ltl:
        result = check_ltl(name, text, formula, cols, machine)
        failed = dict(result.violations)
        marks.append({"name": name, "formula": text, "holds": episode not in failed,
                      "step": failed.get(episode)})
    return marks


def render_episode(run: str | Path, episode: int, shield: Optional[Shield] = None,
                   ltl: Sequence[tuple] = (), adapter=None, salvage: bool = False) -> str:
    """The viewer page of one episode (see the module docstring; ``salvage`` as
    :func:`episode_data`)."""
    return viewer_page(episode_data(run, episode, shield, ltl, adapter, salvage))


def viewer_page(data: dict) -> str:
    """The viewer page showing ``data`` (of :func:`episode_view`)."""
    title = f"{Path(data['file']).name}, episode {data['episode']}"
    fields = {"TITLE": html.escape(title), "DATA": script_json(data)}
    # one pass: a file named {{DATA}}.mcap stays a title
    return re.sub(r"\{\{(TITLE|DATA)\}\}", lambda m: fields[m.group(1)], _TEMPLATE)

