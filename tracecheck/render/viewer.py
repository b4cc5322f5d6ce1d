"""One episode as a self-contained HTML page (inline SVG, CSS and JS; nothing from the web).

A top view of the three-lane road follows the ego vehicle: vehicles drawn to scale as
5 m × 2 m boxes at their centres, the ego vehicle highlighted, velocity arrows. For the chosen
shield, the zones its guards test around the ego vehicle (the regions of the paper's Table 1
for ``paper``) and the actions it blocks. A timeline marks the first infeasible step and the
crash; back, forward and play (buttons and arrow keys). Beside the picture, per step: the
action taken, what the live shield allowed, what the chosen shield allows, the agent's action
values, the reward and the B state.
"""

from __future__ import annotations

import html
import re
from pathlib import Path
from typing import Optional, Sequence

from ..b.values import format_value
from ..episodes.columns import read_columns
from ..episodes.reader import read_run
from ..errors import InputError
from ..checking.shield import Shield
from .jsontext import script_json
from .scene import grid_cells, paper_zones, scene_kind, vehicles

__all__ = ["render_episode", "episode_data"]

_TEMPLATE = (Path(__file__).with_name("viewer.html")).read_text(encoding="utf-8")


def _ids_text(ids: list[int]) -> str:
    ids = sorted(ids)
    if len(ids) > 12:
        return f"{', '.join(map(str, ids[:12]))}, … ({len(ids)} episodes)"
    return ", ".join(map(str, ids))


def episode_data(run: str | Path, episode: int, shield: Optional[Shield] = None,
                 ltl: Sequence[tuple] = ()) -> dict:
    """Everything the viewer shows, as JSON-ready data (``ltl``: (name, text, formula) of
    LTL formulas over ``shield``'s machine, each marked where the episode first violates
    it)."""
    result = read_run(run, {episode})
    if not result.episodes:
        ids = [int(i) for i in read_columns(run).episode_ids]
        if not ids:
            raise InputError(f"{run} holds no complete episode")
        raise InputError(f"{run} has no episode {episode}; it has {_ids_text(ids)}",
                         hint=result.warnings[0] if result.warnings else None)
    ep = result.episodes[0]
    scene = scene_kind(ep.steps[0].state)
    machine = shield.machine if shield is not None else None
    zones = scene == "road" and shield is not None and shield.name == "paper"
    steps = []
    first_infeasible = None
    for k, s in enumerate(ep.steps):
        state = s.state
        enabled = sorted(machine.enabled(state)) if machine is not None else None
        if k and machine is not None and first_infeasible is None:
            if s.action not in steps[-1]["shield_allows"]:
                first_infeasible = k
        ego = "EgoVehicle"
        cars = vehicles(state) if scene == "road" else []
        extra = {}
        if scene == "grid":
            extra = {"agent": [state["x"], state["y"]],
                     "goal": [state["goal_x"], state["goal_y"]]
                     if "goal_x" in state and "goal_y" in state else None}
        steps.append({**extra,
            "step": s.step, "time": s.time, "action": s.action, "reward": s.reward,
            "crashed": s.crashed, "live_allowed": list(s.allowed_actions)
            if s.allowed_actions is not None else None,
            "shield_allows": enabled, "values": dict(s.action_values or {}) or None,
            "preferred": s.preferred_action, "ego": ego, "vehicles": cars,
            "zones": paper_zones(cars, ego) if zones else None,
            "state": {k2: format_value(v) for k2, v in state.items()},
        })
    crash = next((s["step"] for s in steps if s["crashed"]), None)
    return {
        "file": str(run), "episode": ep.id, "seed": ep.seed, "origin": ep.origin,
        "actions": list(result.header.actions) if result.header is not None
        and result.header.actions else sorted({s.action for s in ep.steps if s.action}),
        "scene": scene, "grid": grid_cells(ep.steps[0].state) if scene == "grid" else None,
        "shield": shield.name if shield is not None else None,
        "zones": "paper" if shield is not None and shield.name == "paper" else None,
        "first_infeasible": first_infeasible, "crash_step": crash,
        "ltl": _ltl_marks(run, ep.id, shield, ltl),
        "end": {"steps": ep.end.steps, "reason": ep.end.reason,
                "total_reward": ep.end.total_reward},
        "steps": steps,
    }


def _ltl_marks(run, episode: int, shield: Optional[Shield], ltl: Sequence[tuple]) -> list:
    if not ltl:
        return []
    from ..checking.ltl import check_ltl

    cols = read_columns(run)
    marks = []
    for name, text, formula in ltl:
        result = check_ltl(name, text, formula, cols, shield.machine)
        failed = dict(result.violations)
        marks.append({"name": name, "formula": text, "holds": episode not in failed,
                      "step": failed.get(episode)})
    return marks


def render_episode(run: str | Path, episode: int, shield: Optional[Shield] = None,
                   ltl: Sequence[tuple] = ()) -> str:
    """The viewer page of one episode (see the module docstring)."""
    data = episode_data(run, episode, shield, ltl)
    title = f"{Path(str(run)).name}, episode {episode}"
    fields = {"TITLE": html.escape(title), "DATA": script_json(data)}
    # one pass: a file named {{DATA}}.mcap stays a title
    return re.sub(r"\{\{(TITLE|DATA)\}\}", lambda m: fields[m.group(1)], _TEMPLATE)


def write_page(text: str, out: str | Path, *, force: bool = False,
               inputs: Sequence[Path] = ()) -> Path:
    """Write a page to ``out`` by the output rule (:mod:`tracecheck.outputs`): none of
    ``inputs``, an existing file only with ``force``, renamed into place once complete."""
    from ..outputs import check_output, write_file

    out = check_output(Path(out), inputs, force=force, example="episode.html")
    return write_file(out, text)
