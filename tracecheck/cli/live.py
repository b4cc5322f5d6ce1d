"""Commands that run environments: envs, train, record."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ..errors import InputError
from ..outputs import input_paths
from .common import (SCALE, SHIELD_MODE, continuous_options, external_settings, app, err, out,
                     ENV, ENV_CONFIG, DURATION, record_settings, Algorithm, FORCE, FORMAT, JSON,
                     OutputFormat, output_format, progress, say, warn, SHIELD_HELP)
from .run_options import EXTERNAL_MODE, RunOptions, run_options


@app.command("train")
def train_cmd(
    env: Optional[str] = ENV,
    env_config: list[str] = ENV_CONFIG,
    algorithm: Optional[Algorithm] = typer.Option(
        None, "--algorithm", help="dqn (the default for discrete actions), ppo, a2c (stable-baselines3), maskable-ppo (sb3-contrib) or "
        "q-learning (a Q-table, for environments with discrete observations); for continuous "
        "actions sac (the default), td3, ppo or a2c."),
    shield: Optional[str] = typer.Option(None, "--shield", "-s", help="Train with this shield "
                                         "in the loop: dqn and maskable-ppo explore and exploit "
                                         "only the actions it allows; for ppo and a2c an action "
                                         "it blocks is replaced by the fallback; a continuous "
                                         "action is projected onto the allowed set. "
                                         + SHIELD_HELP),
    intervention_penalty: float = typer.Option(
        0.0, "--intervention-penalty", min=0.0, help="Continuous actions with --shield: lower "
        "each step's reward by this many times the projection distance (default 0: off)."),
    shield_mode: Optional[str] = SHIELD_MODE,
    scale: Optional[str] = SCALE,
    profile: Optional[str] = typer.Option(None, "--profile", help="A named configuration of "
                                          "the environment (`tracecheck envs` lists them; "
                                          "default: its 'base', if it has one); refused for "
                                          "an environment without any."),
    steps: Optional[int] = typer.Option(None, "--steps", min=1, help="Environment steps "
                                        "(default: 20000, 200000 for q-learning)."),
    seed: int = typer.Option(0, "--seed", min=0, max=2**32 - 1, help="Random seed, 0 … "
                             "2^32 - 1 (what stable-baselines3 and NumPy take)."),
    duration: Optional[int] = DURATION,
    output: Path = typer.Option(..., "--output", "-o", help="The agent file to write (.zip, "
                                ".npy for q-learning); its model card NAME.json and learning "
                                "curve NAME.curve.png go beside it."),
    force: bool = FORCE,
) -> None:
    """Train an agent on any environment with an adapter — DQN, PPO, A2C, MaskablePPO, SAC,
    TD3 or a Q-table, with the environment's own settings where it has them — optionally with
    a shield in the loop; a progress bar shows the mean return of the last 20 episodes."""
    from ..live.adapter import load_adapter
    from ..live.settings import parse_config

    adapter = load_adapter(env)
    if algorithm is None:
        algorithm = Algorithm.sac if adapter.parameters else Algorithm.dqn
    profile = _profile(adapter, profile)
    config = adapter.config(parse_config(env_config), profile, duration)
    horizon = duration or adapter.horizon
    if algorithm == Algorithm.q_learning and adapter.parameters:
        raise InputError(f"--algorithm q-learning chooses among discrete actions; "
                         f"{adapter.name} takes continuous ones",
                         hint="give --algorithm sac, td3, ppo or a2c")
    if algorithm == Algorithm.q_learning and shield is not None:
        raise InputError("--algorithm q-learning trains without a shield; with --shield, "
                         "give --algorithm dqn, maskable-ppo, ppo or a2c")
    continuous = continuous_options(shield_mode, scale)
    if (shield_mode is not None or scale is not None) and (shield is None or
                                                            not adapter.parameters):
        raise InputError("--shield-mode and --scale say how --shield moves continuous "
                         f"actions; give them with --shield for an environment that takes "
                         f"some ({adapter.name} "
                         f"{'does' if adapter.parameters else 'does not'})")
    loaded = None
    if shield is not None:
        from ..checking.shield import load_shield

        loaded = load_shield(shield, actions=tuple(adapter.actions),
                             parameters=adapter.parameters)
    steps = steps or (200_000 if algorithm == Algorithm.q_learning else 20_000)
    under = f" under {loaded.name}" if loaded is not None else ""
    with progress(f"training {algorithm.value} on {adapter.name}{under}", steps, "steps",
                  detail=", mean return {task.fields[mean]}", mean="-") as advance:

        def report(done: int, total: int, mean: Optional[float]) -> None:
            advance(0, completed=done, total=total,
                    mean="-" if mean is None else f"{mean:.2f}")

        card = _train(adapter, config, algorithm, loaded, steps=steps, seed=seed,
                      horizon=horizon, profile=profile,
                      progress=report, output=output, force=force,
                      inputs=input_paths(shield), intervention_penalty=intervention_penalty,
                      **continuous)
    _say_trained(card, output)


def _profile(adapter, profile: Optional[str]) -> Optional[str]:
    """The named configuration to train in: the one given (the environment must have it),
    else its ``base`` where it has one (the model card names it), else none."""
    if profile is None:
        return "base" if "base" in adapter.profiles else None
    if not adapter.profiles:
        raise InputError(f"--profile {profile}: the environment {adapter.name} has no named "
                         "configurations (`tracecheck envs` lists each environment's)",
                         hint="leave --profile out; set the environment's own settings with "
                              "--env-config key=value")
    return profile


def _train(adapter, config: dict, algorithm: Algorithm, shield, *, output: Path,
           profile: Optional[str], **options):
    """Train with the learner of ``algorithm``; the learning curve drawn by render/curves."""
    from ..render.curves import learning_curve

    if algorithm == Algorithm.q_learning:
        from ..live.training import train_q_table

        for key in ("intervention_penalty", "shield_mode", "scale"):
            options.pop(key, None)
        return train_q_table(adapter, config, output, draw_curve=learning_curve, **options)
    from ..live.training import Training, train_agent

    progress, force, inputs = options.pop("progress"), options.pop("force"), options.pop("inputs")
    return train_agent(adapter, config, algorithm.value, output,
                       Training(profile=profile, **options), shield=shield, progress=progress,
                       force=force, inputs=inputs, draw_curve=learning_curve)


def _say_trained(card: dict, output: Path) -> None:
    """What was trained, how the shield reached it, the last mean return, and the files."""
    from ..live.training import shielding_text

    curve = card["learning_curve"]
    mean = curve["mean_return_last"]
    result = (f"mean return of the last {min(curve['window'], curve['episodes'])} of "
              f"{curve['episodes']} episodes {mean:.2f}" if mean is not None else
              "no episode finished")
    say(f"trained {card['agent']} ({card['algorithm']} on {card['environment']}"
        f"{shielding_text(card)}, {card['steps']} steps, seed {card['seed']}) in "
        f"{card['wall_time_s']:.1f} s; {result} -> {output}; model card "
        f"{output.with_suffix('.json')}, learning curve {output.parent / curve['file']}")


@app.command("record")
@run_options
def record_cmd(
    run: RunOptions,
    episodes: int = typer.Option(..., "--episodes", "-n", min=1, help="How many episodes."),
) -> None:
    """Run an agent under a shield (pre-shielding) and record every episode to MCAP — or,
    with --external, an agent script that speaks SimB's external-simulation protocol, the
    shield's machine answering it as ProB would."""
    if run.mode == EXTERNAL_MODE:
        settings, machine = external_settings(run, episodes)
        _record_external(settings, machine, run.output, run.force)
        return
    import time as _time

    from ..interop.foxglove import FoxgloveChannels
    from ..live.record import record

    settings = record_settings(run, episodes)
    output, force, shield = run.output, run.force, run.shield
    stats = {"crashes": 0, "steps": 0, "episodes": 0}
    existed = output.exists()
    start = _time.perf_counter()
    with progress("recording", episodes, detail=", {task.fields[crashes]} crash(es), "
                  "{task.fields[rate]} steps/s", crashes=0, rate="-") as advance:

        def report(ep) -> None:
            stats["episodes"] += 1
            stats["crashes"] += ep.end.crashed
            stats["steps"] += ep.end.steps
            stats["fallbacks"] = stats.get("fallbacks", 0) + ep.deadlocks
            stats["problems"] = stats.get("problems", 0) + ep.problems
            if ep.first_problem and "first_problem" not in stats:
                stats["first_problem"] = (ep.id, *ep.first_problem)
            rate = stats["steps"] / max(_time.perf_counter() - start, 1e-9)
            advance(crashes=stats["crashes"], rate=f"{rate:.0f}")

        try:
            n, steps, crashes = record(settings, output, report, force=force,
                                       channels=FoxgloveChannels.drawn_by(settings.env))
        except KeyboardInterrupt:
            err.print(f"interrupted: {output} keeps every finished episode" if stats["episodes"]
                      else f"interrupted before an episode was finished: {output} was not "
                      + ("changed" if existed else "written"), markup=False)
            raise typer.Exit(130) from None
        except Exception:  # noqa: BLE001 - said as it is, after what was kept
            if stats["episodes"]:
                err.print(_kept("the recording failed", output, stats["episodes"], existed),
                          markup=False)
            raise
    took = _time.perf_counter() - start
    fallbacks = stats.get("fallbacks", 0)
    nothing = (f", {fallbacks} step(s) where the shield allowed nothing and the fallback "
               "was taken" if fallbacks else "")
    say(f"recorded {n} episode(s), {steps} step(s), {crashes} crash(es){nothing} with shield "
        f"{shield} in {took:.1f} s ({steps / took:.0f} steps/s) -> {output}")
    if stats.get("problems"):
        episode, step, why = stats["first_problem"]
        warn([f"in {stats['problems']} step(s) the shield could not evaluate a guard, and "
              f"did not allow its action (it failed closed; each step's shield_problem says "
              f"why); the first, episode {episode} step {step}: {why}"])


def _record_external(settings, machine, output: Path, force: bool) -> None:
    """``record --external``: the script's episodes, what the machine found in them, and
    what was kept when the script failed."""
    import shlex
    import time as _time

    from ..errors import TracecheckError
    from ..interop.foxglove import FoxgloveChannels
    from ..live.external import record_external

    seen = {"episodes": 0, "blocked": 0, "crashes": 0}
    existed = output.exists()
    start = _time.perf_counter()
    with progress("recording", settings.episodes, detail=", {task.fields[blocked]} blocked "
                  "action(s)", blocked=0) as advance:

        def report(ep) -> None:
            seen["episodes"] += 1
            seen["blocked"] += sum(1 for s in ep.steps[1:]
                                   if s.allowed_actions is not None
                                   and s.action not in s.allowed_actions)
            advance(blocked=seen["blocked"])

        try:
            n, steps, crashes = record_external(settings, machine, output, report,
                                                force=force, channels=FoxgloveChannels)
        except KeyboardInterrupt:
            err.print(_kept("interrupted", output, seen["episodes"], existed), markup=False)
            raise typer.Exit(130) from None
        except TracecheckError:
            if seen["episodes"]:
                err.print(_kept("the script failed", output, seen["episodes"], existed),
                          markup=False)
            raise
    took = _time.perf_counter() - start
    say(f"recorded {n} episode(s), {steps} step(s), {crashes} crash(es) from "
        f"{shlex.join(settings.command)} answered by {machine.name} in {took:.1f} s; "
        f"{seen['blocked']} step(s) took an action {machine.name} did not enable -> {output}")
    if seen["blocked"]:
        say(f"replay them: tracecheck replay {shlex.quote(str(output))} --shield "
            f"{shlex.quote(str(machine.path))}")


def _kept(what: str, output: Path, episodes: int, existed: bool) -> str:
    if episodes:
        return f"{what}: {output} keeps the {episodes} episode(s) finished before"
    return (f"{what} before an episode was finished: {output} was not "
            + ("changed" if existed else "written"))



@app.command("envs")
def envs_cmd(
    as_json: bool = JSON,
    fmt: OutputFormat = FORMAT,
) -> None:
    """List the environments: what each is, its actions and state variables, the shields and
    property sets it brings, its profiles and horizon, and whether the packages it needs are
    installed."""
    import importlib.util

    from ..live.adapter import adapters
    from ..render.emit import emit
    from ..render.listing_text import EnvsOutput

    fmt = output_format(fmt, as_json)
    rows = []
    for info in adapters():
        a = info.adapter
        row = {"name": info.name, "adapter": info.target, "problem": info.problem}
        if a is not None:
            missing = [p for p in a.requires if importlib.util.find_spec(p) is None]
            row.update(environment=a.env_id, description=a.description,
                       actions=list(a.actions), variables=list(a.variables),
                       default_shield=a.default_shield, shields=sorted(a.shields),
                       property_sets=sorted(a.property_sets), profiles=sorted(a.profiles),
                       fallback=a.fallback, horizon=a.horizon, installed=not missing,
                       missing=missing)
            if a.parameters:  # continuous: each action with the parameters it binds
                row["parameters"] = {op: list(p) for op, p in a.parameters.items()}
            if a.reset_parameters:  # what falsify --param may set at an episode's start
                row["reset_parameters"] = dict(a.reset_parameters)
        rows.append(row)
    emit(EnvsOutput(rows), fmt.value, out)
