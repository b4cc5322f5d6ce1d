"""``tracecheck falsify``'s optimisers against uniform random on problems whose violations are
rare under random sampling (benchmarks/falsify_problems.py): each optimiser runs R
independent searches of the same budget through the whole pipeline (every evaluation an
episode written to a run file), as ARCH-COMP's falsification track counts: the falsification
rate and the episodes to the first violation (each search ends at its first violation, as
in ARCH-COMP: ``--stop-at-first``).

    python benchmarks/bench_falsify.py [--repeat 10] [--budget 300] [--problem NAME …]
        [--optimizer NAME …]

Printed per problem: its violating share (exact for the needle and the corner, measured by
Monte Carlo for the brake) and uniform random's expected median from it, then per optimiser
the searches that found a violation, the episodes
to the first (median, mean, min, max over those searches; a search that found none counts
as budget + 1 in the median over all searches) and the wall time per search; and whether the
best guided optimiser's median over all searches is at most random's / 3 with a
falsification rate at least random's.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks import falsify_problems as P  # noqa: E402

OPTIMIZERS = ("random", "halton", "cmaes", "tpe", "gp")

#: name: (adapter, --param texts, STL property, the violating share: (share, how known))
PROBLEMS = {
    "needle": ("benchmarks.falsify_problems:Needle", ("a=0.0..1.0", "b=0.0..1.0"),
               f"G({{d > {P.R!r}}})", (0.005, "a disc of area 0.005")),
    "corner": ("benchmarks.falsify_problems:Corner", ("x=0.0..1.0", "y=0.0..1.0", "z=0.0..1.0"),
               f"G({{s < {P.CORNER}}})", (0.2 ** 3 / 6, "a corner of volume 0.2^3 / 6")),
    "brake": ("benchmarks.falsify_problems:Brake", ("t=0.0..1.0", "k=0.0..1.0", "u=0.0..1.0"),
              "G({gap > 0.0})", None),
    # the same crashes, as the default property (no crash) guided by the shield's margins
    "brake-margin": ("benchmarks.falsify_problems:Brake",
                     ("t=0.0..1.0", "k=0.0..1.0", "u=0.0..1.0"), None, None),
}


def brake_share(n: int = 50_000) -> float:
    """The brake problem's violating share, from ``n`` uniform points (seeded) run in its
    environment under its shield's rule directly."""
    import numpy as np

    bad = 0
    for t, k, u in np.random.default_rng(2026).random((n, 3)):
        env = P.BrakeEnv(t=float(t), k=float(k), u=float(u))
        env.reset(seed=0)
        for _ in range(P.BrakeEnv.STEPS):
            speed, lead, gap = env.speed, env.lead, env.gap
            keep = (gap - (speed * speed - lead * lead) / 16.0 > 7.6) if speed > lead \
                else gap > 7.6
            _, _, crashed, truncated, _ = env.step(0 if keep else (1 if speed > 0 else 2))
            if crashed or truncated:
                bad += bool(crashed)
                break
    return bad / n


def expected_median(share: float, budget: int) -> int:
    """The median of the episodes to the first violation of uniform random sampling, a search
    that finds none counted as budget + 1: the first k with 1 - (1 - share)^k >= 1/2."""
    import math

    k = math.ceil(math.log(0.5) / math.log(1.0 - share))
    return k if k <= budget else budget + 1


def run_problem(name: str, repeat: int, budget: int, folder: Path,
                optimizers: tuple[str, ...] = OPTIMIZERS) -> dict:
    from tracecheck.live.rollout import RecordSettings
    from tracecheck.search.falsify import FalsifySettings, falsify

    env, params, prop, _ = PROBLEMS[name]
    actions = 3 if name.startswith("brake") else 1
    agent = P.agent_table(folder / f"{name}.npy", actions)
    shield = str(folder / f"{name}.mch")
    Path(shield).write_text({"needle": P.NEEDLE_MACHINE, "corner": P.CORNER_MACHINE,
                             "brake": P.BRAKE_SHIELD, "brake-margin": P.BRAKE_SHIELD}[name])
    rows = {}
    for optimizer in optimizers:
        settings = FalsifySettings(
            RecordSettings(agent=agent, shield=shield, episodes=1, env=env), params, prop,
            budget=budget, optimizer=optimizer, repeat=repeat, seed=0, baseline=False,
            attribute=0, stop_at_first=True)
        start = time.perf_counter()
        result = falsify(settings, folder / f"{name}-{optimizer}.mcap", force=True)
        took = time.perf_counter() - start
        reps = result.repetitions
        firsts = [r.first_violation for r in reps if r.first_violation is not None]
        every = [r.first_violation if r.first_violation is not None else budget + 1
                 for r in reps]
        rows[optimizer] = {
            "falsified": len(firsts), "rate": len(firsts) / repeat,
            "median": statistics.median(firsts) if firsts else None,
            "mean": statistics.fmean(firsts) if firsts else None,
            "min": min(firsts) if firsts else None, "max": max(firsts) if firsts else None,
            "median_all": statistics.median(every), "s_per_search": took / repeat}
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=10)
    parser.add_argument("--budget", type=int, default=300)
    parser.add_argument("--problem", action="append", choices=sorted(PROBLEMS))
    parser.add_argument("--optimizer", action="append", choices=OPTIMIZERS,
                        help="random always runs (the baseline)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.problem or list(PROBLEMS):
            share, how = PROBLEMS[name][3] or (brake_share(), "of 50 000 uniform points")
            print(f"\n{name}: violating share {100 * share:.3g} % ({how}); {args.repeat} "
                  f"searches of {args.budget} episodes per optimiser; uniform random's "
                  f"expected median over all searches "
                  f"{expected_median(share, args.budget)}")
            chosen = ("random", *[o for o in OPTIMIZERS if o != "random"
                                  and o in (args.optimizer or OPTIMIZERS)])
            rows = run_problem(name, args.repeat, args.budget, Path(tmp), chosen)
            print(f"  {'optimizer':10} {'falsified':>9} {'median':>7} {'mean':>7} {'min':>5} "
                  f"{'max':>5} {'median, all':>12} {'s/search':>9}")
            for opt, r in rows.items():
                def f(x):
                    return "-" if x is None else f"{x:g}"
                print(f"  {opt:10} {r['falsified']:>6}/{args.repeat:<2} {f(r['median']):>7} "
                      f"{f(r['mean']):>7} {f(r['min']):>5} {f(r['max']):>5} "
                      f"{f(r['median_all']):>12} {r['s_per_search']:>9.2f}")
            rand = rows["random"]
            guided = min((o for o in chosen if o != "random"),
                         key=lambda o: rows[o]["median_all"])
            best = rows[guided]
            ok = best["median_all"] <= rand["median_all"] / 3 and best["rate"] >= rand["rate"]
            expected = expected_median(share, args.budget)
            print(f"  best guided: {guided}, median over all searches {best['median_all']:g} "
                  f"vs random's {rand['median_all']:g} measured (ratio "
                  f"{rand['median_all'] / best['median_all']:.1f}x; "
                  f"{expected / best['median_all']:.1f}x against random's expected {expected}),"
                  f" rate {best['rate']:.0%} vs {rand['rate']:.0%}: "
                  f"{'goal met' if ok else 'goal NOT met'} (measured random)")


if __name__ == "__main__":
    main()
