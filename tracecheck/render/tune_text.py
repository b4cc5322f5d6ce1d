"""What ``tracecheck tune`` prints: the figures for every value of the tuned number (each piece
of its range), the Pareto front with its knee, and the machine's own value — in every format
(:mod:`.emit`)."""

from __future__ import annotations

from typing import Optional

from ..search.tune_sweep import Figures, Piece
from .emit import Report
from .tables import TableData

__all__ = ["TuneOutput", "RepairOutput", "PairOutput", "figures_data"]


def figures_data(f: Figures, crashes: int) -> dict:
    """One set of figures as JSON, with the crashes no blocked step came before."""
    return {"steps_blocked": f.steps_blocked, "episodes_blocked": f.episodes_blocked,
            "crashes_after_blocked": f.crashes_after_blocked,
            "crashes_missed": crashes - f.crashes_after_blocked,
            "deadlock_states": f.deadlock_states}


def _piece(p: Piece) -> dict:
    return {"low": float(p.low), "high": float(p.high), "low_closed": p.low_closed,
            "high_closed": p.high_closed, "values": p.text()}


class TuneOutput(Report):
    """A :class:`~tracecheck.search.tuning.TuneResult` for people and machines."""

    def __init__(self, result, plot: Optional[str] = None,
                 resimulation: Optional[dict] = None) -> None:
        self.result, self.plot, self.resimulation = result, plot, resimulation

    def data(self) -> dict:
        r, t = self.result, self.result.target
        on_front = {id(p) for f in r.front for p in f.pieces}
        return {
            "shield": r.shield, "files": r.files,
            "parameter": {"name": t.label, "kind": t.kind, "value": t.value,
                          "integer": t.integer, "line": t.line, "column": t.column},
            "range": [r.low, r.high], "method": r.method,
            "episodes": r.episodes, "steps": r.steps, "crashes": r.crashes,
            "current": figures_data(r.current, r.crashes),
            "at": [{"value": v, **figures_data(f, r.crashes)} for v, f in r.at.items()],
            "pieces": [{**_piece(p), **figures_data(p.figures, r.crashes),
                        "on_front": id(p) in on_front} for p in r.pieces],
            "front": [{"value": f.value, "values": [p.text() for p in f.pieces],
                       **figures_data(f.figures, r.crashes)} for f in r.front],
            "knee": None if r.knee is None else r.knee.value,
            "deadlock_note": r.deadlock_note, "warnings": r.warnings, "plot": self.plot,
            "resimulation": self.resimulation, "elapsed_s": r.elapsed_s,
        }

    def table(self) -> TableData:
        r = self.result
        on_front = {id(p) for f in r.front for p in f.pieces}
        current = float(r.target.value)
        rows = []
        for p in r.pieces:
            f = p.figures
            marks = [m for m, yes in (("machine's", p.contains(_fraction(current))),
                                      ("front", id(p) in on_front)) if yes]
            rows.append([p.text(), str(f.steps_blocked), str(f.episodes_blocked),
                         str(f.crashes_after_blocked),
                         str(r.crashes - f.crashes_after_blocked),
                         "" if f.deadlock_states is None else str(f.deadlock_states),
                         ", ".join(marks)])
        return TableData.of([f"{r.target.label} values", "steps blocked", "episodes blocked",
                             "crashes at/after a blocked step", "crashes not blocked",
                             "deadlock states", "note"], rows)

    def text(self, console) -> None:
        r, t = self.result, self.result.target

        def shown(x) -> str:  # an INTEGER's values as integers: at 2, not at 2.0
            return str(int(x)) if t.integer and float(x).is_integer() else str(x)
        how = (f"exact for every value in [{shown(r.low)}, {shown(r.high)}]: "
               f"{len(r.pieces)} piece(s)"
               if r.method == "exact" else
               f"at {len(r.at)} value(s) only (each replayed with it written in)")
        console.print(f"{t.label} ({t.kind} at {t.where}, {t.value} in the machine) over "
                      f"{r.episodes:,} episode(s), {r.steps:,} step(s), {r.crashes:,} "
                      f"crash(es): {how}", markup=False)
        for v, f in r.at.items():
            own = " (the machine's; replay says the same)" if v == float(t.value) else ""
            console.print(f"  at {shown(v)}{own}: {_line(f, r.crashes)}", markup=False)
        console.print(f"Pareto front (fewest steps blocked, fewest crashes not blocked): "
                      f"{len(r.front)} point(s)", markup=False)
        for f in r.front:
            knee = "  <- knee" if r.knee is not None and f is r.knee else ""
            values = ", ".join(p.text() for p in f.pieces[:3]) + (
                f" and {len(f.pieces) - 3} more" if len(f.pieces) > 3 else "")
            console.print(f"  {values}: {_line(f.figures, r.crashes)}{knee}", markup=False)
        if r.deadlock_note:
            console.print(f"deadlock states {r.deadlock_note}", markup=False)
        if self.resimulation:
            _resimulation_text(console, self.resimulation)
        if self.plot:
            console.print(f"plot: {self.plot}", markup=False)
        for w in r.warnings:
            console.print(f"warning: {w}", markup=False)


def _line(f: Figures, crashes: int) -> str:
    dead = "" if f.deadlock_states is None else f", {f.deadlock_states:,} deadlock state(s)"
    return (f"{f.steps_blocked:,} step(s) blocked in {f.episodes_blocked:,} episode(s); "
            f"{f.crashes_after_blocked:,} of {crashes:,} crash(es) at or after a blocked "
            f"step{dead}")


def _fraction(x: float):
    from fractions import Fraction

    return Fraction(x)


def _resimulation_text(console, resim: dict) -> None:
    console.print(f"re-simulated {resim['episodes']} episode(s) per value from their seeds "
                  f"({resim['interval']} intervals, {resim['confidence']:.0%}):", markup=False)
    for row in resim["values"]:
        console.print(f"  {row['label']}: crashes {row['crashes']} "
                      f"({row['crash_rate']:.3f}, {row['crash_low']:.3f}..{row['crash_high']:.3f}); "
                      f"interventions per step {row['intervention_rate']:.3f} "
                      f"({row['intervention_low']:.3f}..{row['intervention_high']:.3f})"
                      + (f"; against the machine's: {row['paired']}" if row.get("paired")
                         else ""), markup=False)


class RepairOutput(Report):
    """A :class:`~tracecheck.search.repair.RepairResult` for people and machines."""

    def __init__(self, result) -> None:
        self.result = result

    def data(self) -> dict:
        from dataclasses import asdict

        r = self.result
        return {"shield": r.shield, "gap": asdict(r.gap),
                "candidates": [{**asdict(c), "change": c.change} for c in r.candidates],
                "chosen": None if r.chosen is None else asdict(r.chosen),
                "output": r.output, "newly_blocked": r.newly_blocked,
                "newly_allowed": r.newly_allowed, "episodes_changed": r.episodes_changed,
                "deadlock_free": r.deadlock_free, "symbolic_diff": r.symbolic}

    def table(self) -> TableData:
        r = self.result
        return TableData.of(["number", "current", "blocking value", "change", "note"],
                            [[c.label, f"{c.current:g}", "" if c.value is None else repr(c.value),
                              "" if c.change is None else f"{c.change:.3%}",
                              ("chosen" if c is r.chosen else "") + (c.why if c.value is None
                                                                     else "")]
                             for c in r.candidates])

    def text(self, console) -> None:
        r, g = self.result, self.result.gap
        console.print(f"{g.path}, episode {g.episode}: crashed at step {g.crash_step} with no "
                      f"step before blocked; to block: {g.action} at step {g.step} ({g.reason})",
                      markup=False)
        for c in r.candidates:
            what = (f"{c.value!r} (from {c.current:g}, {c.change:.3%})" if c.value is not None
                    else f"cannot close it: {c.why}")
            console.print(f"  {c.label}: {what}" + ("  <- the smallest change"
                                                   if c is r.chosen else ""), markup=False)
        if r.chosen is None:
            console.print("no single number of the shield closes the gap", markup=False)
            return
        if r.chosen.value == r.chosen.current:
            console.print(f"{r.chosen.label} blocks the action already", markup=False)
            return
        console.print(f"on the recordings: {r.newly_blocked:,} step(s) newly blocked, "
                      f"{r.newly_allowed:,} newly allowed, in {r.episodes_changed:,} "
                      f"episode(s)", markup=False)
        console.print(f"written: {r.output}" if r.output else "not written", markup=False)
        console.print("deadlock-free: " + ", ".join(f"{k} {v}" for k, v in
                                                    r.deadlock_free.items()), markup=False)
        for s in r.symbolic:
            detail = f": {s['detail']}" if s["detail"] else ""
            console.print(f"  diff --symbolic {s['operation']}: {s['status']}{detail}",
                          markup=False)


class PairOutput(Report):
    """A :class:`~tracecheck.search.tune_pair.PairResult` for people and machines."""

    def __init__(self, result, plot: Optional[str] = None) -> None:
        self.result, self.plot = result, plot

    def _lines(self):
        r = self.result
        a, b = r.targets
        for axis, other, lines in ((a, b, r.along_first), (b, a, r.along_second)):
            for v, tuned in lines:
                yield axis, other, v, tuned

    def data(self) -> dict:
        r = self.result
        return {
            "shield": r.shield, "parameters": [t.label for t in r.targets],
            "ranges": [list(x) for x in r.ranges], "grids": [list(g) for g in r.grids],
            "lines": [{"along": axis.label, "fixed": other.label, "fixed_value": v,
                       "pieces": [{**_piece(p), **figures_data(p.figures, t.crashes)}
                                  for p in t.pieces],
                       "front": [{"value": f.value, **figures_data(f.figures, t.crashes)}
                                 for f in t.front]}
                      for axis, other, v, t in self._lines()],
            "crossings": [{r.targets[0].label: x, r.targets[1].label: y,
                           **figures_data(t.at[x], t.crashes)}
                          for y, t in r.along_first for x in r.grids[0]],
            "plot": self.plot, "elapsed_s": r.elapsed_s,
        }

    def table(self) -> TableData:
        rows = []
        for axis, other, v, t in self._lines():
            for p in t.pieces:
                f = p.figures
                rows.append([axis.label, f"{other.label} = {v:g}", p.text(),
                             str(f.steps_blocked), str(f.episodes_blocked),
                             str(f.crashes_after_blocked), str(t.crashes - f.crashes_after_blocked),
                             "" if f.deadlock_states is None else str(f.deadlock_states)])
        return TableData.of(["along", "fixed", "values", "steps blocked", "episodes blocked",
                             "crashes at/after a blocked step", "crashes not blocked",
                             "deadlock states"], rows)

    def text(self, console) -> None:
        r = self.result
        a, b = r.targets
        console.print(f"{a.label} over {r.ranges[0][0]}..{r.ranges[0][1]} and {b.label} over "
                      f"{r.ranges[1][0]}..{r.ranges[1][1]}: a grid of {len(r.grids[0])} × "
                      f"{len(r.grids[1])} values, exact along each line", markup=False)
        console.print(f"steps blocked / crashes not blocked where the lines cross ({a.label} "
                      f"down, {b.label} across):", markup=False)
        console.print("  " + " ".join(f"{y:>14g}" for y in r.grids[1]), markup=False)
        by = {y: t for y, t in r.along_first}
        for x in r.grids[0]:
            cells = []
            for y in r.grids[1]:
                f = by[y].at[x]
                cells.append(f"{f.steps_blocked}/{by[y].crashes - f.crashes_after_blocked}")
            console.print(f"  {x:g}: " + " ".join(f"{c:>14}" for c in cells), markup=False)
        for axis, other, v, t in self._lines():
            best = t.knee
            knee = "" if best is None else (f"; knee {axis.label} = {best.value:g}: "
                                            f"{_line(best.figures, t.crashes)}")
            console.print(f"along {axis.label} with {other.label} = {v:g}: {len(t.pieces)} "
                          f"piece(s){knee}", markup=False)
