"""What the shield costs in vectorised training: MaskablePPO on 16 FrozenLake sub-environments.

Issue 46's yardstick: the shield's share of a training step at most 30 % against the same
training unshielded. Three trainings of the same size, interleaved, each repeated; medians:

* **bare** — ``DummyVecEnv`` of 16 FrozenLake environments (the bundled adapter's settings),
  each under sb3-contrib's ``ActionMasker`` allowing every action (MaskablePPO needs masks);
* **one by one** — each sub-environment in a ``ShieldWrapper`` under the ``frozenlake`` shield,
  each deciding its own state (what ``tracecheck.live.wrapper`` alone gives);
* **together** — the same, the vector environment in ``ShieldedVecEnv``
  (:mod:`tracecheck.live.vector_sb3`): one decision for all sub-environments per step.

The shield's share of a training step is (shielded − bare) / shielded. Also printed: the
decision per state of the ``paper`` shield on highway states, one by one against batches of
16 and 256 (what the batch evaluator would cost a vector environment of the highway; the
shield takes the faster way it measures).

    python benchmarks/bench_vector.py [--steps 32768] [--repeat 5]
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings

import numpy as np

N_ENVS = 16


def _train(kind: str, steps: int) -> float:
    from sb3_contrib import MaskablePPO
    from sb3_contrib.common.wrappers import ActionMasker
    from stable_baselines3.common.vec_env import DummyVecEnv

    from tracecheck.checking.shield import load_shield
    from tracecheck.live.adapter import get_adapter
    from tracecheck.live.vector_sb3 import ShieldedVecEnv
    from tracecheck.live.wrapper import ShieldWrapper

    adapter = get_adapter("frozenlake")
    shield = load_shield("frozenlake")
    n = len(adapter.actions)

    def bare():
        return ActionMasker(adapter.make_env(adapter.config(None)),
                            lambda env: np.ones(n, dtype=bool))

    def shielded():
        return ShieldWrapper(adapter.make_env(adapter.config(None)), shield, adapter=adapter)

    venv = DummyVecEnv([bare if kind == "bare" else shielded] * N_ENVS)
    if kind == "together":
        venv = ShieldedVecEnv(venv)
    model = MaskablePPO("MlpPolicy", venv, n_steps=128, batch_size=512, n_epochs=1, seed=0,
                        device="cpu")
    start = time.perf_counter()
    model.learn(steps)
    return time.perf_counter() - start


def _highway_decisions(states_n: int = 512) -> dict[str, float]:
    """µs per state of the paper shield's decisions on highway states."""
    from tracecheck.checking.shield import load_shield
    from tracecheck.live.adapter import get_adapter
    from tracecheck.live.decisions import Decisions
    from tracecheck.live.wrapper import ShieldWrapper

    adapter = get_adapter("highway")
    shield = load_shield("paper")
    env = ShieldWrapper(adapter.make_env(adapter.config(None)), shield, adapter=adapter)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    states = []
    while len(states) < states_n:
        states.append(env.state)
        _, _, terminated, truncated, _ = env.step(int(rng.integers(len(env.actions))))
        if terminated or truncated:
            env.reset(seed=int(rng.integers(1000)))
    out = {}
    for label, size in (("one by one", 1), ("batch of 16", 16), ("batch of 256", 256)):
        decisions = Decisions(shield.machine, env.actions)
        decisions._memoise = False  # every state decided (a highway's rarely repeat)
        decisions._prefer_batch = lambda: True  # this benchmark times the batch path itself
        timer = time.perf_counter()
        if size == 1:
            [decisions.one(s) for s in states]
        else:
            for k in range(0, len(states), size):
                block = states[k:k + size]
                if size >= 32:
                    decisions.many(block)
                else:  # below BATCH_MIN many() decides one by one: time the batch itself
                    decisions._batched(block)
        out[label] = (time.perf_counter() - timer) * 1e6 / len(states)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=32768, help="training steps per run")
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    warnings.filterwarnings("ignore")
    kinds = ("bare", "one by one", "together")
    _train("together", 2048)  # imports and first compilations out of the way
    times: dict[str, list[float]] = {k: [] for k in kinds}
    for _ in range(args.repeat):
        for kind in kinds:
            times[kind].append(_train(kind, args.steps))
    med = {k: statistics.median(v) for k, v in times.items()}
    print(f"MaskablePPO, {N_ENVS} FrozenLake sub-environments, {args.steps} steps, "
          f"medians of {args.repeat}:")
    for kind in kinds:
        share = (med[kind] - med["bare"]) / med[kind]
        extra = "" if kind == "bare" else \
            f"  ({med[kind] / med['bare']:.2f}× bare; the shield's share {share:.0%})"
        per = med[kind] / args.steps * 1e6
        print(f"  {kind:<11} {med[kind]:.3f} s  {per:.1f} µs per sub-environment step{extra}")
    share = (med["together"] - med["bare"]) / med["together"]
    print(f"issue 46: the shield's share of a training step <= 30 %: "
          f"{'met' if share <= 0.30 else 'NOT met'} ({share:.0%})")
    print("the paper shield on highway states, µs per state:",
          ", ".join(f"{k} {v:.1f}" for k, v in _highway_decisions().items()))


if __name__ == "__main__":
    main()
