"""The live decision against a hand-written check of the same rule, per state.

Issue 46's yardstick: what ``ShieldWrapper`` spends deciding a state at most 5× what a
hand-written check of the same rule costs, for

* **discrete** — the ``paper`` shield's five guards (``models/shields/paper.mch``, Table 1 of
  the paper) on highway states (random actions from seeded resets of the bundled highway
  environment), against ``benchmarks/handwritten_check.py``'s ``enabled`` (the same guards
  in plain Python, checked here to agree on every state): tracecheck's decision as the
  wrapper makes it (:class:`tracecheck.live.decisions.Decisions`, as it runs after a first
  pass of states: its memo, which such states never hit, given up), each pass on states of
  its own;
* **1-D continuous** — a double integrator before a wall (``ACCELERATE(a)``: position ``x``,
  speed ``v``, a step of ``DT``; the guard keeps the next position before the wall and the
  next speed under the limit), against its closed form (the largest allowed ``a``, the
  proposal clipped to it): tracecheck's decision as the wrapper makes it for a continuous
  action (:class:`tracecheck.live.continuous.ContinuousShield`: the allowed set, then the
  projection of a random proposal), checked to give the closed form's action on every state.

Medians of ``--repeat`` passes over the states, each pass timing every state once.

    python benchmarks/bench_live.py [--states 400] [--repeat 7]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import handwritten_check  # noqa: E402

WALL, VMAX, DT, LOW, HIGH = 10.0, 2.0, 0.1, -1.0, 1.0
INTEGRATOR = f"""
MACHINE DoubleIntegrator
VARIABLES x, v
INVARIANT x : REAL & v : REAL
INITIALISATION x := 0.0 || v := 0.0
OPERATIONS
  ACCELERATE(a) = SELECT a : REAL & x + v * {DT} + {DT * DT / 2} * a <= {WALL}
                         & v + {DT} * a <= {VMAX}
                  THEN x := x + v * {DT} + {DT * DT / 2} * a || v := v + {DT} * a END
END
"""


def closed_form(x: float, v: float, proposal: float) -> tuple[bool, float]:
    """(anything allowed, the action taken): the largest allowed ``a`` within the action
    space's bounds, the proposal clipped to it (the fallback ``LOW`` when nothing is)."""
    top = min(HIGH, (WALL - x - v * DT) / (DT * DT / 2), (VMAX - v) / DT)
    if top < LOW:
        return False, LOW
    return True, min(max(proposal, LOW), top)


def _hand_state(state: dict) -> dict:
    """A B state of the highway in handwritten_check's own form."""
    return {"present": {str(e) for e in state["PresentVehicles"]},
            "x": {str(k): v for k, v in state["VehiclesX"].map.items()},
            "y": {str(k): v for k, v in state["VehiclesY"].map.items()},
            "vx": {str(k): v for k, v in state["VehiclesVx"].map.items()}}


def discrete(n: int, repeat: int) -> tuple[float, float]:
    from tracecheck.checking.shield import load_shield
    from tracecheck.live.adapter import get_adapter
    from tracecheck.live.decisions import Decisions
    from tracecheck.live.wrapper import ShieldWrapper

    adapter = get_adapter("highway")
    shield = load_shield("paper")
    env = ShieldWrapper(adapter.make_env(adapter.config(None)), shield, adapter=adapter)
    rng = np.random.default_rng(0)
    env.reset(seed=0)
    states = []  # each pass its own states, as a live shield meets them: one to warm up
    while len(states) < n * (repeat + 1):
        states.append(dict(env.state))
        _, _, terminated, truncated, _ = env.step(int(rng.integers(len(env.actions))))
        if terminated or truncated:
            env.reset(seed=len(states))
    hand = [_hand_state(s) for s in states]
    decisions = Decisions(shield.machine, env.actions)
    for s, h in zip(states[:n], hand[:n]):  # the warm-up pass, checked
        assert set(decisions.one(s).allowed) == handwritten_check.enabled(h), s
    ours, theirs = [], []
    for k in range(1, repeat + 1):
        chunk = slice(k * n, (k + 1) * n)
        start = time.perf_counter()
        for s in states[chunk]:
            decisions.one(s)
        ours.append((time.perf_counter() - start) / n)
        start = time.perf_counter()
        for h in hand[chunk]:
            handwritten_check.enabled(h)
        theirs.append((time.perf_counter() - start) / n)
    for s, h in zip(states, hand):
        assert set(decisions.one(s).allowed) == handwritten_check.enabled(h), s
    return statistics.median(ours) * 1e6, statistics.median(theirs) * 1e6


def continuous(n: int, repeat: int) -> tuple[float, float]:
    import gymnasium as gym

    from tracecheck.b.machine import load_machine_text
    from tracecheck.live.adapter import EnvAdapter
    from tracecheck.live.continuous import ContinuousShield

    class Integrator(EnvAdapter):
        name = "integrator"
        actions = ("ACCELERATE",)
        parameters = {"ACCELERATE": ("a",)}
        fallback_action = (LOW,)
        variables = ("x", "v")

    machine = load_machine_text(INTEGRATOR)
    space = gym.spaces.Box(LOW, HIGH, (1,), dtype=np.float64)
    shield = ContinuousShield(machine, Integrator(), space, mode="project")
    rng = np.random.default_rng(1)
    states = [{"x": float(x), "v": float(v)}
              for x, v in zip(rng.uniform(0.0, 10.5, n), rng.uniform(-1.0, 2.5, n))]
    proposals = rng.uniform(LOW, HIGH, n).tolist()
    envs = [machine.env(s) for s in states]
    for s, env, p in zip(states, envs, proposals):
        shield.decide(env)
        d = shield.filter([p])
        ok, taken = closed_form(s["x"], s["v"], p)
        assert d.deadlock == (not ok), (s, p)
        assert not ok or abs(float(d.executed[0]) - taken) <= 1e-9 * max(1.0, abs(taken)), \
            (s, p, d.executed, taken)
    ours, theirs = [], []
    for _ in range(repeat):
        start = time.perf_counter()
        for env, p in zip(envs, proposals):
            shield.decide(env)
            shield.filter([p])
        ours.append((time.perf_counter() - start) / n)
        start = time.perf_counter()
        for s, p in zip(states, proposals):
            closed_form(s["x"], s["v"], p)
        theirs.append((time.perf_counter() - start) / n)
    return statistics.median(ours) * 1e6, statistics.median(theirs) * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--states", type=int, default=400)
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    print("| rule | tracecheck's live decision | hand-written | ratio | issue 46: ≤ 5× |")
    print("|---|---|---|---|---|")
    for label, (ours, theirs) in (
            ("paper's five guards, highway states", discrete(args.states, args.repeat)),
            ("1-D double integrator before a wall, with projection",
             continuous(args.states, args.repeat))):
        ratio = ours / theirs
        print(f"| {label} | {ours:.2f} µs | {theirs:.2f} µs | {ratio:.1f}× | "
              f"{'met' if ratio <= 5 else 'not met'} |")


if __name__ == "__main__":
    main()
