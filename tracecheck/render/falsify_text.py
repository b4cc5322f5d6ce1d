"""What ``tracecheck falsify`` prints: per optimiser, ARCH-COMP's figures (falsification
rate, episodes to the first violation), and each repetition."""

from __future__ import annotations

from dataclasses import asdict
from typing import Optional

from ..search.attribution import KINDS
from .emit import Report
from .tables import TableData

__all__ = ["FalsifyOutput", "point_text"]


#: the violating episodes the text lists (JSON lists every one)
SHOWN = 10


def _number(x: Optional[float], empty: str = "-") -> str:
    if x is None:
        return empty
    return f"{x:g}" if isinstance(x, float) else str(x)


def point_text(parameters: dict) -> str:
    """A search point's parameters as ``name=value, …`` (reals to 6 digits)."""
    return ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                     for k, v in parameters.items())


class FalsifyOutput(Report):
    """A :class:`~tracecheck.search.falsify.FalsifyResult` for people and machines."""

    def __init__(self, result, plot: Optional[str] = None) -> None:
        self.result, self.plot = result, plot

    def data(self) -> dict:
        r = self.result
        return {"property": r.property, "logic": r.logic, "space": r.space,
                "choices": list(r.choices),
                "budget": r.budget, "output": r.output,
                "optimizers": [asdict(s) for s in r.summaries],
                "repetitions": [asdict(x) for x in r.repetitions],
                "violations": [{"episode": v.episode, **asdict(v.point)}
                               for v in r.violations],
                "plot": self.plot}

    def table(self) -> TableData:
        return TableData.of(
            ["optimizer", "repetitions", "falsified", "rate", "first mean", "first median",
             "first min", "first max", "violations", "episodes", *KINDS],
            ([s.optimizer, str(s.repetitions), str(s.falsified), f"{s.rate:.2f}",
              _number(s.first_mean, ""), _number(s.first_median, ""),
              _number(s.first_min, ""), _number(s.first_max, ""), str(s.violations),
              str(s.evaluations),
              *(str(s.attributions.get(k, 0)) for k in KINDS)]
             for s in self.result.summaries))

    def text(self, console) -> None:
        r = self.result
        space = ", ".join(f"{k} in {{{', '.join(map(str, v))}}}" if k in r.choices
                          or len(v) != 2 else f"{k} in {v[0]}..{v[1]}"
                          for k, v in r.space.items())
        console.print(f"property {r.property} ({r.logic}) over {space}; {r.budget} "
                      f"episode(s) per search", markup=False)
        for s in r.summaries:
            first = (f"first violation after {_number(s.first_median)} episode(s) (median; "
                     f"mean {_number(s.first_mean)}, min {_number(s.first_min)}, max "
                     f"{_number(s.first_max)})" if s.falsified else
                     "no violation found within the budget")
            console.print(f"{s.optimizer}: {s.falsified} of {s.repetitions} search(es) "
                          f"falsified ({s.rate:.0%}), {s.violations} violating episode(s) of "
                          f"{s.evaluations}; {first}", markup=False)
            if s.attributions:
                console.print("  attributed: " + ", ".join(
                    f"{n} {kind}" for kind, n in sorted(s.attributions.items())),
                    markup=False)
        for v in r.violations[:SHOWN]:
            p = v.point
            why = (f"; {p.attribution}" + (f" at step {p.attribution_step}"
                                           if p.attribution_step is not None else "")
                   + (f": {p.attribution_detail}" if p.attribution_detail else "")
                   if p.attribution else "")
            console.print(f"  episode {v.episode} ({p.optimizer}, search {p.repetition}, "
                          f"evaluation {p.evaluation + 1}): {point_text(p.parameters)}; objective "
                          f"{p.objective:g}{why}", markup=False)
        if len(r.violations) > SHOWN:
            console.print(f"  … {len(r.violations) - SHOWN} more violating episode(s): --json "
                          "lists every one", markup=False)
        console.print(f"every episode -> {r.output}"
                      + (f"; the objective over the search -> {self.plot}" if self.plot
                         else ""), markup=False)
