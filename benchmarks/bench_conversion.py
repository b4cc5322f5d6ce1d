"""Benchmark: the one state conversion (issue 42) against the numpy-only conversion it replaced.

Every recorded, trained or re-simulated step converts the adapter's state at the machine's
boundary. Before issue 42 that was ``native_state`` (numpy values only, by the variables'
types for arrays); now it is ``convert_state`` (by the machine's types: a str naming an element,
a dict for a function, arrays by the invariant's index sets). Measured in one run, per state,
median of ``--repeat`` timings of ``--n`` conversions:

* the highway's state (the paper's shield), as its adapter gives it (B values already);
* FrozenLake's state under its shield (a map of 64 cells, the same object every step);
* a user's state of Python values (an element as a str, a 7×7 numpy map of names, a set) —
  which the old boundary could not convert at all (only the new time is shown).

    python benchmarks/bench_conversion.py [--n 20000] [--repeat 5]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from tracecheck.b.conversion import convert_state, native_state
from tracecheck.b.machine import load_machine_text
from tracecheck.checking.shield import load_shield


def _timed(fn, n: int, repeat: int) -> float:
    """Median seconds per call of ``fn`` over ``repeat`` runs of ``n`` calls."""
    runs = []
    for _ in range(repeat):
        start = time.perf_counter()
        for _ in range(n):
            fn()
        runs.append((time.perf_counter() - start) / n)
    return statistics.median(runs)


def _highway_state():
    from tracecheck.live.envs.highway import HighwayAdapter

    adapter = HighwayAdapter()
    env = adapter.make_env(adapter.config(None))
    obs, info = env.reset(seed=0)
    state = adapter.observer(env).state(obs, dict(info, crashed=False), 0.0, True)
    env.close()
    return state


def _lake_state():
    from tracecheck.live.envs.frozenlake import FrozenLakeAdapter

    adapter = FrozenLakeAdapter()
    env = adapter.make_env(adapter.config(None))
    obs, info = env.reset(seed=0)
    return adapter.observer(env).state(obs, dict(info, crashed=False), 0.0, True)


USER = """MACHINE Lava
SETS CELL = {Floor, Wall, Lava, Goal}
VARIABLES ahead, grid, seen, x
INVARIANT ahead : CELL & grid : (0..6)*(0..6) --> CELL & seen : POW(CELL) & x : 0..6
INITIALISATION ahead := Floor || grid := (0..6)*(0..6) * {Floor} || seen := {} || x := 0
OPERATIONS Forward = SELECT ahead /= Lava THEN skip END
END
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=20000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    cases = [("highway (paper)", load_shield("paper").machine, _highway_state()),
             ("frozenlake", load_shield("frozenlake").machine, _lake_state())]
    print(f"{'state':<22} {'before µs':>10} {'after µs':>10} {'ratio':>7}")
    for name, machine, state in cases:
        types, kinds = machine.type_objects, machine.state_types()
        before = _timed(lambda s=state, t=types: native_state(s, t), args.n, args.repeat)
        after = _timed(lambda s=state, k=kinds: convert_state(s, k), args.n, args.repeat)
        print(f"{name:<22} {before * 1e6:>10.2f} {after * 1e6:>10.2f} {after / before:>7.2f}")
    user = load_machine_text(USER)
    grid = np.full((7, 7), "Floor")
    grid[3, 4] = "Lava"
    state = {"ahead": "Lava", "grid": grid, "seen": {"Wall", "Lava"}, "x": np.int64(3)}
    after = _timed(lambda: convert_state(state, user.state_types()), args.n // 10, args.repeat)
    print(f"{'user (str, 7×7 array)':<22} {'-':>10} {after * 1e6:>10.2f} {'-':>7}")


if __name__ == "__main__":
    main()
