"""Commands that run environments: envs, train, record."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ..errors import InputError
from ..outputs import input_paths
from .common import (app, out, err, Executor, EPISODE_EXECUTOR, RAY_ADDRESS, Profile, ENV,
                     ENV_CONFIG, PROFILE, DURATION, AGENT, record_settings, Algorithm, FORCE,
                     RUN_SHIELD, SEED, WORKERS, FORMAT, JSON, OutputFormat, output_format,
                     print_json, print_table, progress, say, SHIELD_HELP)


@app.command("train")
def train_cmd(
    env: Optional[str] = ENV,
    env_config: list[str] = ENV_CONFIG,
    algorithm: Algorithm = typer.Option(Algorithm.dqn, "--algorithm", help="dqn (the paper's "
                                        "settings on the highway; masked under --shield), "
                                        "maskable-ppo (sb3-contrib, with --shield) or "
                                        "q-learning (a Q-table, for environments with discrete "
                                        "observations)."),
    shield: Optional[str] = typer.Option(None, "--shield", "-s", help="Train with this shield "
                                         "in the loop: the agent explores and exploits only "
                                         "the actions it allows. " + SHIELD_HELP),
    profile: Profile = typer.Option(Profile.base, "--profile", help="Reward profile."),
    steps: Optional[int] = typer.Option(None, "--steps", min=1, help="Environment steps "
                                        "(default: 20000 for dqn and maskable-ppo, 200000 for "
                                        "q-learning)."),
    seed: int = typer.Option(0, "--seed", min=0, max=2**32 - 1, help="Random seed, 0 … "
                             "2^32 - 1 (what stable-baselines3 and NumPy take)."),
    duration: Optional[int] = DURATION,
    output: Path = typer.Option(..., "--output", "-o", help="The agent file to write (.zip "
                                "for dqn and maskable-ppo, .npy for q-learning; its model card "
                                "NAME.json goes beside it)."),
    force: bool = FORCE,
) -> None:
    """Train an agent: a DQN with the paper's settings on the highway, a Q-table, or — with
    --shield — a DQN or MaskablePPO that only ever takes what the shield allows."""
    from ..live.agents import train
    from ..live.adapter import load_adapter, parse_config

    adapter = load_adapter(env)
    if shield is not None or algorithm == Algorithm.maskable_ppo:
        _train_shielded(adapter, parse_config(env_config), shield or "none", algorithm,
                        profile, steps, seed, duration, output, force)
        return
    if algorithm == Algorithm.q_learning:
        from ..live.agents import train_q_table

        card = train_q_table(adapter, adapter.config(parse_config(env_config)), output,
                             steps=steps or 200_000, seed=seed,
                             horizon=duration or adapter.horizon, force=force)
        out.print(f"trained {card['agent']} (Q-learning on {adapter.name}, {card['steps']} "
                  f"steps, seed {seed}) in {card['wall_time_s']:.1f} s -> {output}; model "
                  f"card {Path(output).with_suffix('.json')}", markup=False)
        return
    if adapter.name != "highway":
        raise InputError(f"--algorithm dqn trains the paper's highway agent; for {adapter.name} "
                         "use --algorithm q-learning, or give --shield")
    steps = steps or 20_000
    config = adapter.config(parse_config(env_config), profile.value, duration or 60)
    with progress(f"training {profile.value}", steps, "steps") as advance:
        card = train(profile.value, output, steps=steps, seed=seed, duration=duration or 60,
                     progress=lambda done, total: advance(0, completed=done), force=force,
                     config=config)
    out.print(f"trained {card['agent']} ({profile.value}, {steps} steps, seed {seed}) in "
              f"{card['wall_time_s']:.0f} s -> {output}; model card "
              f"{Path(output).with_suffix('.json')}", markup=False)


def _train_shielded(adapter, env_config: dict, shield: str, algorithm: Algorithm, profile,
                    steps: Optional[int], seed: int, duration: Optional[int],
                    output: Path, force: bool) -> None:
    from ..checking.shield import load_shield
    from ..live.training import train_shielded

    if algorithm == Algorithm.q_learning:
        raise InputError("shielded training takes --algorithm dqn or maskable-ppo")
    loaded = load_shield(shield, actions=tuple(adapter.actions))
    profile_name = profile.value if adapter.name == "highway" else None
    config = adapter.config(env_config, profile_name, duration)
    steps = steps or 20_000
    with progress(f"training under {loaded.name}", steps, "steps") as advance:
        card = train_shielded(adapter, config, loaded, algorithm.value, output, steps=steps,
                              seed=seed, progress=lambda done, total: advance(0, completed=done),
                              force=force, inputs=input_paths(shield))
    say(f"trained {card['agent']} ({card['algorithm']} under shield {loaded.name}, {steps} "
          f"steps, seed {seed}) in {card['wall_time_s']:.0f} s -> {output}; model card "
          f"{Path(output).with_suffix('.json')}")


@app.command("record")
def record_cmd(
    agent: Path = AGENT,
    shield: str = RUN_SHIELD,
    episodes: int = typer.Option(..., "--episodes", "-n", min=1, help="How many episodes."),
    seed: int = SEED,
    env: Optional[str] = ENV,
    env_config: list[str] = ENV_CONFIG,
    duration: Optional[int] = DURATION,
    workers: int = WORKERS,
    executor: Executor = EPISODE_EXECUTOR,
    ray_address: Optional[str] = RAY_ADDRESS,
    profile: Optional[str] = PROFILE,
    fallback: Optional[str] = typer.Option(None, "--fallback",
                                           help="Action taken when the shield allows nothing "
                                                "(default: the environment's; highway SLOWER)."),
    output: Path = typer.Option(..., "--output", "-o", help="The MCAP file to write."),
    force: bool = FORCE,
) -> None:
    """Run an agent under a shield (pre-shielding) and record every episode to MCAP."""
    import time as _time

    from ..live.record import record

    settings = record_settings(env, env_config, agent=str(agent), shield=shield, episodes=episodes,
                         seed=seed, duration=duration, profile=profile, fallback=fallback,
                         workers=workers, executor=executor.value, ray_address=ray_address)
    stats = {"crashes": 0, "steps": 0}
    start = _time.perf_counter()
    with progress("recording", episodes, detail=", {task.fields[crashes]} crash(es), "
                  "{task.fields[rate]} steps/s", crashes=0, rate="-") as advance:

        def report(ep) -> None:
            stats["crashes"] += ep.end.crashed
            stats["steps"] += ep.end.steps
            rate = stats["steps"] / max(_time.perf_counter() - start, 1e-9)
            advance(crashes=stats["crashes"], rate=f"{rate:.0f}")

        try:
            n, steps, crashes = record(settings, output, report, force=force)
        except KeyboardInterrupt:
            err.print(f"interrupted: {output} keeps every finished episode")
            raise typer.Exit(130) from None
    took = _time.perf_counter() - start
    say(f"recorded {n} episode(s), {steps} step(s), {crashes} crash(es) with shield "
        f"{shield} in {took:.1f} s ({steps / took:.0f} steps/s) -> {output}")



@app.command("envs")
def envs_cmd(
    as_json: bool = JSON,
    fmt: OutputFormat = FORMAT,
) -> None:
    """List the environment adapters: actions, state variables, default shield, and whether
    the packages they need are installed."""
    import importlib.util

    from ..live.adapter import adapters
    from ..render.tables import TableData

    fmt = output_format(fmt, as_json)
    rows = []
    for info in adapters():
        a = info.adapter
        row = {"name": info.name, "adapter": info.target, "problem": info.problem}
        if a is not None:
            missing = [p for p in a.requires if importlib.util.find_spec(p) is None]
            row.update(environment=a.env_id, actions=list(a.actions),
                       variables=list(a.variables), default_shield=a.default_shield,
                       horizon=a.horizon, installed=not missing, missing=missing)
        rows.append(row)
    if fmt == OutputFormat.json:
        print_json(rows)
        return
    table = TableData.of(
        ["name", "environment", "actions", "variables", "shield", "installed"],
        ([r["name"], r["adapter"], "", "", "", f"no: {r['problem']}"] if r["problem"] else
         [r["name"], r["environment"], ", ".join(r["actions"]), ", ".join(r["variables"]),
          r["default_shield"] or "",
          "yes" if r["installed"] else "no: needs " + ", ".join(r["missing"])]
         for r in rows))
    if fmt != OutputFormat.text:
        print_table(fmt, table)
        return
    for name, environment, actions, variables, shield, installed in table.rows:
        if not actions:  # a block per environment, wrapped between items
            say(f"{name} ({environment}): {installed}")
            continue
        say(f"{name} ({environment}), shield {shield or '(none)'}, installed: {installed}")
        say(f"  actions: {actions}", "    ")
        say(f"  variables: {variables}", "    ")
