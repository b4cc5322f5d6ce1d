"""What continuous actions cost: the live decision with projection, and replay.

**Live decision** — what :class:`~tracecheck.live.wrapper.ShieldWrapper` does in a state for a
continuous action (the allowed set, whether anything is allowed, the projection of a random
proposal, the allowed intervals), median over states of a real episode, for

* 1-D: the throttle shield of tests/fixtures (``ACCELERATE(a)``, one linear constraint);
* 2-D: the built-in ``highway_continuous`` (``DRIVE(acceleration, steering)``: the RSS
  bound over the vehicles ahead, steering rules) on highway-continuous states, and
  ``lunarlander_continuous`` (``FIRE(main, lateral)``) on lander states;
* hybrid: the cruise control of tests/fixtures choosing ACCELERATE(a), BRAKE(b) or KEEP
  (``hybrid_v1.mch``, mask mode: every operation's allowed set, the best-scored enabled one
  projected);
* not linear: the throttle with a guard quadratic in ``a`` (``Gap * 8.0 > (EgoSpeed + a) *
  (EgoSpeed + a)``), decided by the solver (z3) within its 0.5 s budget per state;

against the baseline of one unshielded highway-continuous environment step (median), the
issue's yardstick (goal: at most 1 %).

**Replay** — the whole ``tracecheck replay --json`` process on a continuous run (the
throttle environment, a controller that keeps some headway: most steps allowed, some not)
against the same on a discrete run of the same episodes and steps (the three-action cruise
control under its acc_v2 shield), interleaved fresh processes, medians: time and peak memory
(goal: the continuous one at least 50 % of the discrete one's speed).

    python benchmarks/bench_continuous.py [--episodes 1000] [--steps 100] [--repeat 5]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
ACC = ROOT / "tests" / "fixtures" / "acc_env"
sys.path.insert(0, str(ACC))

from acc_cruise import CruiseEnv  # noqa: E402
from acc_cruise.hybrid import SHIELD as HYBRID_SHIELD, Hybrid, HybridEnv  # noqa: E402
from acc_cruise.throttle import SHIELD_V1, Throttle, ThrottleEnv  # noqa: E402
from tracecheck.checking.shield import load_shield  # noqa: E402
from tracecheck.episodes.files import write_run  # noqa: E402
from tracecheck.episodes.model import Episode, StepRecord, make_end  # noqa: E402
from tracecheck.episodes.writer import new_header  # noqa: E402
from tracecheck.live.adapter import get_adapter  # noqa: E402
from tracecheck.live.continuous import ContinuousShield  # noqa: E402

ACC_V2 = ACC / "acc_cruise" / "acc_v2.mch"
RUNNER = ("import resource, sys\nfrom tracecheck.cli import main\ntry:\n    main(sys.argv[1:])\n"
          "finally:\n    print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, "
          "file=sys.stderr)\n")


def live_states(adapter, env, n: int, machine) -> list[dict]:
    """``n`` states of random episodes (random actions)."""
    observer = adapter.observer(env)
    obs, info = env.reset(seed=0)
    states = []
    while len(states) < n:
        obs, reward, term, trunc, info = env.step(env.action_space.sample())
        states.append(machine.native(observer.state(obs, dict(info, crashed=False), reward,
                                                    False)))
        if term or trunc:
            obs, info = env.reset(seed=len(states))
            observer = adapter.observer(env)
    return states


def decision_us(adapter, env, shield, states) -> float:
    continuous = ContinuousShield(shield.machine, adapter, env.action_space)
    rng = np.random.default_rng(0)
    space = continuous.agent_space  # a hybrid space's: scores, then every parameter
    low, high = space.low, space.high
    times = []
    for state in states:
        proposal = rng.uniform(low, high)
        env_ = shield.machine.env(state)
        start = time.perf_counter()
        continuous.decide(env_)
        continuous.any_allowed()
        continuous.filter(proposal)
        continuous.bands()
        times.append(time.perf_counter() - start)
    return statistics.median(times) * 1e6


def highway_step_us(n: int) -> float:
    adapter = get_adapter("highway-continuous")
    env = adapter.make_env(adapter.config())
    env.reset(seed=0)
    times = []
    for k in range(n):
        start = time.perf_counter()
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        times.append(time.perf_counter() - start)
        if term or trunc:
            env.reset(seed=k)
    return statistics.median(times) * 1e6


def live(n: int) -> None:
    step = highway_step_us(n)
    print(f"unshielded highway-continuous step: median {step:,.0f} µs over {n} steps")
    cases = [("1-D throttle (tests/fixtures)", Throttle(), ThrottleEnv(), SHIELD_V1)]
    for name in ("highway-continuous", "lunarlander-continuous"):
        adapter = get_adapter(name)
        cases.append((f"2-D {name}", adapter, adapter.make_env(adapter.config()),
                      adapter.default_shield))
    cases.append(("hybrid: ACCELERATE(a), BRAKE(b), KEEP (tests/fixtures)", Hybrid(),
                  HybridEnv(), HYBRID_SHIELD))
    with tempfile.TemporaryDirectory() as tmp:
        quadratic = Path(tmp) / "throttle_quadratic.mch"
        quadratic.write_text(SHIELD_V1.read_text().replace(
            "Gap + LeadSpeed - 1.0 - (EgoSpeed + a) > EgoSpeed + a",
            "Gap * 8.0 > (EgoSpeed + a) * (EgoSpeed + a)"))
        cases.append(("1-D throttle, guard not linear (the solver)", Throttle(), ThrottleEnv(),
                      quadratic))
        print("| shield | decision (median µs) | of a highway step |\n|---|---|---|")
        for label, adapter, env, spec in cases:
            shield = load_shield(spec)
            us = decision_us(adapter, env, shield,
                             live_states(adapter, env, n, shield.machine))
            print(f"| {label} | {us:,.0f} | {us / step:.1%} |")


def episodes(n: int, steps: int, continuous: bool):
    """``n`` episodes of up to ``steps`` steps: the throttle under a controller that keeps
    a headway (its acceleration, with noise, recorded as the parameter a), or the same
    controller's acceleration rounded to the three discrete actions."""
    for i in range(n):
        env = ThrottleEnv(max_steps=steps) if continuous else CruiseEnv(max_steps=steps)
        rng = np.random.default_rng(i)
        obs, _ = env.reset(seed=i)
        state = {"Gap": float(obs[0]), "EgoSpeed": float(obs[1]), "LeadSpeed": float(obs[2])}
        records = [StepRecord(0, 0.0, None, state, 0.0, False)]
        for k in range(1, steps + 1):
            gap, ego, lead = (float(x) for x in obs)
            bound = (gap + lead - 1 - 2 * ego) / 2  # throttle_v1 allows a below it
            want = float(np.clip(min(bound, 2.0) - 0.5 + rng.normal(0, 0.5), -4.0, 2.0))
            if continuous:
                action, name, params = [want], "ACCELERATE", {"a": want}
            else:
                code = 1 if want > 1.0 else 2 if want < -2.0 else 0
                action, name, params = code, ("KEEP", "ACCEL", "BRAKE")[code], None
            obs, reward, term, trunc, _ = env.step(action)
            state = {"Gap": float(obs[0]), "EgoSpeed": float(obs[1]),
                     "LeadSpeed": float(obs[2])}
            records.append(StepRecord(k, float(k), name, state, float(reward), bool(term),
                                      parameters=params))
            if term or trunc:
                break
        records = tuple(records)
        yield Episode(i, records, make_end(records, "crashed" if records[-1].crashed
                                           else "time-limit"), seed=i)


def process(args: list[str]) -> tuple[float, float]:
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", RUNNER, *args], capture_output=True,
                          text=True, cwd=ROOT)
    wall = time.perf_counter() - start
    if done.returncode not in (0, 1):
        raise SystemExit(done.stderr)
    return wall, int(done.stderr.strip().splitlines()[-1]) / 1024


def replays(n: int, steps: int, repeat: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        cont, disc = Path(tmp) / "continuous.mcap", Path(tmp) / "discrete.mcap"
        write_run(cont, new_header("recorded", variables=["Gap", "EgoSpeed", "LeadSpeed"],
                                   actions=["ACCELERATE"],
                                   action_parameters={"ACCELERATE": ["a"]},
                                   action_low=[-4.0], action_high=[2.0]),
                  episodes(n, steps, True))
        write_run(disc, new_header("recorded", variables=["Gap", "EgoSpeed", "LeadSpeed"],
                                   actions=["KEEP", "ACCEL", "BRAKE"]),
                  episodes(n, steps, False))
        jobs = {"continuous": ["replay", str(cont), "--shield", str(SHIELD_V1), "--json"],
                "discrete": ["replay", str(disc), "--shield", str(ACC_V2), "--json"]}
        found: dict[str, list] = {k: [] for k in jobs}
        for _ in range(repeat):
            for name, args in jobs.items():
                found[name].append(process(args))
        out = subprocess.run([sys.executable, "-c", RUNNER, *jobs["continuous"]],
                             capture_output=True, text=True, cwd=ROOT).stdout
        import json

        report = json.loads(out)
        print(f"\ncontinuous run: {report['episodes']} episodes, {report['steps']} steps, "
              f"{report['infeasible_steps']} infeasible, {report['deadlock_states']} deadlock "
              "states")
        print("| replay --json, whole process | median s | peak MiB | speed vs discrete |"
              "\n|---|---|---|---|")
        base = statistics.median(w for w, _ in found["discrete"])
        for name, runs in found.items():
            wall = statistics.median(w for w, _ in runs)
            mem = statistics.median(m for _, m in runs)
            print(f"| {name} | {wall:.2f} | {mem:.0f} | {base / wall:.0%} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--episodes", type=int, default=1000)
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--states", type=int, default=200, help="states for the decision")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--only", choices=("live", "replay"))
    args = parser.parse_args()
    if args.only != "replay":
        live(args.states)
    if args.only != "live":
        replays(args.episodes, args.steps, args.repeat)


if __name__ == "__main__":
    main()
