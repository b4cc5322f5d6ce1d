"""Minari datasets both ways (Farama's offline-RL standard; ``pip install 'tracecheck[minari]'``).

Export: every episode of a run becomes a Minari episode — observations (n + 1), actions as
the environment's action indices, rewards, terminations (the episode crashed or ended in a
terminal state) and truncations (it hit its time limit), and the episode's seed. ``infos``
follow Gymnasium's pairing: entry j describes the step that led to observation j (entry 0 is
the reset), with

* ``allowed`` — the live shield's mask over the actions (all false at the reset and where the
  run recorded none),
* ``intervened`` — the shield replaced the agent's preferred action,
* ``deadlock`` — the shield allowed nothing and the fallback was taken,
* ``preferred`` — the index of the agent's unshielded choice (-1 where none was recorded),
* ``action_values`` — the agent's values of each action in the state before (NaN where none
  were recorded),
* ``b_state`` — the B state as JSON (UTF-8 bytes), as ``guards --state`` reads it.

The dataset's metadata names the agent, the shield and its sha256 (``tracecheck`` key, and the
description); its environment spec is the recorded one, so ``recover_environment()`` makes
the same environment when its package is installed.

Import: a Minari dataset's episodes, given an adapter that turns observations into B states,
become a run file that replay, diff and stats read like a recording; the infos above, where a
dataset has them, come back as the steps' allowed actions, preferred action, action values and
deadlock flag, so a run exported and imported again replays exactly like the original.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path
from typing import Iterator, Optional

import numpy as np

from ..errors import InputError

__all__ = ["export_minari", "import_minari"]


def _minari():
    try:
        import minari
    except ImportError:
        raise InputError("Minari is not installed", hint="pip install 'tracecheck[minari]'") \
            from None
    return minari


def _recorded_adapter(header, run: Path):
    """The installed adapter a run file names (by name, or for files from before adapters
    were named, by environment id) — never a module named inside the file."""
    from ..live.adapter import adapters, get_adapter

    name = header.environment
    if not name and header.environment_id:
        name = next((a.name for a in adapters()
                     if a.adapter is not None and a.adapter.env_id == header.environment_id),
                    None)
    if not name:
        raise InputError(f"{run} names no environment adapter; Minari needs the environment's "
                         "spaces", hint="give the adapter with --env")
    return get_adapter(name)


def _make_env(adapter, config: Optional[dict], what: str):
    try:
        return adapter.make_env(adapter.config(config or {}))
    except InputError:
        raise
    except Exception as exc:  # a package missing, a configuration the environment rejects
        raise InputError(f"{what}: cannot make the environment {adapter.env_id}: {exc}") \
            from None


def _observation(rows, space, where: str):
    if rows is None:
        raise InputError(f"{where} has no observation (imported traces record none); a Minari "
                         "dataset needs the observations of a recording")
    value = np.asarray(rows, dtype=np.float64)
    if space.shape == ():
        if value.size != 1 or not float(value.reshape(-1)[0]).is_integer():
            raise InputError(f"{where}: the observation {value.tolist()!r} is not one of "
                             f"{space}")
        return np.asarray(value.reshape(-1)[0]).astype(space.dtype)
    if value.size != int(np.prod(space.shape)):
        raise InputError(f"{where}: an observation of shape {value.shape} does not fit the "
                         f"environment's {space} (was it recorded with another configuration?)")
    return value.reshape(space.shape).astype(space.dtype)


def export_minari(run: Path, dataset_id: str, *, env: Optional[str] = None,
                  progress=lambda: None):
    """Write the episodes of ``run`` as the local Minari dataset ``dataset_id``; the dataset.
    ``env``: the adapter as the user names it (default: the installed one the file names)."""
    from ..live.adapter import load_adapter

    from ..episodes.codec import encode_state
    from ..episodes.reader import read_run

    minari = _minari()
    from minari.data_collector.episode_buffer import EpisodeBuffer

    result = read_run(run)
    header = result.header
    if not result.episodes:
        raise InputError(f"{run} holds no complete episode")
    adapter = load_adapter(env) if env else _recorded_adapter(header, run)
    made = _make_env(adapter, header.environment_config, str(run))
    actions = list(adapter.actions)
    buffers = []
    for ep in result.episodes:
        where = f"{run}, episode {ep.id}"
        obs = [_observation(s.observation, made.observation_space, f"{where}, step {s.step}")
               for s in ep.steps]
        try:
            acts = [actions.index(s.action) for s in ep.steps[1:]]
        except ValueError:
            bad = next(s for s in ep.steps[1:] if s.action not in actions)
            raise InputError(f"{where}, step {bad.step}: action {bad.action!r} is not one of "
                             f"{adapter.name}'s ({', '.join(actions)})") from None
        n = len(acts)
        last = ep.end.reason
        infos = {"allowed": np.zeros((n + 1, len(actions)), dtype=bool),
                 "intervened": np.zeros(n + 1, dtype=bool),
                 "deadlock": np.zeros(n + 1, dtype=bool),
                 "preferred": np.full(n + 1, -1, dtype=np.int64),
                 "action_values": np.full((n + 1, len(actions)), np.nan),
                 "b_state": np.array([json.dumps(encode_state(s.state)).encode()
                                      for s in ep.steps], dtype=object)}
        for j, s in enumerate(ep.steps[1:], start=1):
            for a in s.allowed_actions or ():
                infos["allowed"][j, actions.index(a)] = True
            infos["intervened"][j] = (s.preferred_action is not None
                                      and s.preferred_action != s.action)
            infos["deadlock"][j] = bool(s.deadlock)
            if s.preferred_action in actions:
                infos["preferred"][j] = actions.index(s.preferred_action)
            for a, v in (s.action_values or {}).items():
                if a in actions:
                    infos["action_values"][j, actions.index(a)] = v
        buffers.append(EpisodeBuffer(
            id=ep.id, seed=ep.seed, observations=obs, actions=acts,
            rewards=[float(s.reward) for s in ep.steps[1:]],
            terminations=[False] * (n - 1) + [last != "time-limit"] if n else [],
            truncations=[False] * (n - 1) + [last == "time-limit"] if n else [],
            infos=infos))
        progress()
    shield = header.shield_name or "none"
    about = {"run": str(run), "agent": header.agent_id, "agent_sha256": header.agent_sha256,
             "shield": shield, "shield_sha256": header.shield_sha256,
             "environment": adapter.name, "actions": actions}
    try:
        with warnings.catch_warnings():  # its advice to add an e-mail address and a link
            warnings.simplefilter("ignore", UserWarning)
            dataset = minari.create_dataset_from_buffers(
                dataset_id=dataset_id, buffer=buffers, env=made.spec,
                algorithm_name=header.agent_id or "unknown", author="tracecheck", description=(
                    f"Episodes of agent {header.agent_id or 'unknown'} under the B shield "
                    f"{shield} (sha256 {header.shield_sha256 or '-'}), recorded by tracecheck. "
                    f"infos: allowed (shield mask over {', '.join(actions)}), intervened, "
                    "deadlock, b_state (JSON)."),
                action_space=made.action_space, observation_space=made.observation_space,
                data_format="hdf5")
    except ValueError as exc:  # minari's own checks: an id taken or malformed
        raise InputError(f"cannot create the Minari dataset {dataset_id}: {exc}") from None
    dataset.storage.update_metadata({"tracecheck": json.dumps(about)})
    made.close()
    return dataset


def _action_index(value, count: int, where: str) -> int:
    """A discrete action: one integer in 0 … count-1 (a float, a vector or a value out of
    range is refused, never rounded or cut to fit)."""
    a = np.asarray(value)
    if a.size != 1 or a.dtype.kind not in "iu":
        raise InputError(f"{where}: the action {a.tolist()!r} is not an action index; the "
                         f"adapter has {count} discrete actions")
    index = int(a.reshape(-1)[0])
    if not 0 <= index < count:
        raise InputError(f"{where}: action {index} is not one of the adapter's {count} actions")
    return index


def _check_lengths(data, n: int, where: str) -> None:
    """n actions, rewards, terminations and truncations; n + 1 observations."""
    for name, want in (("rewards", n), ("terminations", n), ("truncations", n),
                       ("observations", n + 1)):
        got = len(getattr(data, name))
        if got != want:
            raise InputError(f"{where}: {got} {name} for {n} actions (want {want})")


def _shield_infos(infos, k: int, n: int, actions) -> dict:
    """What tracecheck's own infos say of step ``k`` (nothing for other datasets, or where a
    value is missing or malformed)."""
    if not k or not isinstance(infos, dict):
        return {}

    def column(name, shape):
        value = infos.get(name)
        if value is None or np.shape(value) != shape:
            return None
        return np.asarray(value)[k]

    out = {}
    allowed = column("allowed", (n + 1, len(actions)))
    if allowed is not None and allowed.dtype == bool and allowed.any():
        out["allowed_actions"] = tuple(a for a, on in zip(actions, allowed) if on)
    preferred = column("preferred", (n + 1,))
    if preferred is not None and preferred.dtype.kind in "iu" \
            and 0 <= int(preferred) < len(actions):
        out["preferred_action"] = actions[int(preferred)]
    values = column("action_values", (n + 1, len(actions)))
    if values is not None and np.isfinite(values).all():
        out["action_values"] = {a: float(v) for a, v in zip(actions, values)}
    deadlock = column("deadlock", (n + 1,))
    if deadlock is not None and bool(deadlock):  # the shield allowed nothing (as recorded:
        out.update(allowed_actions=(), deadlock=True)  # true, or no flag at all)
    return out


def _provenance(text, dataset_id: str) -> dict:
    """Agent and shield of a dataset tracecheck exported (its ``tracecheck`` metadata key);
    {} for other datasets. Malformed provenance is refused, not guessed at."""
    if text is None:
        return {}
    try:
        meta = json.loads(text) if isinstance(text, (str, bytes)) else None
    except ValueError:
        meta = None
    keys = ("agent", "agent_sha256", "shield", "shield_sha256")
    if not isinstance(meta, dict) or not all(meta.get(k) is None or isinstance(meta[k], str)
                                             for k in keys):
        raise InputError(f"{dataset_id}: its 'tracecheck' metadata is not what tracecheck "
                         "writes (a JSON object naming agent and shield)")
    return meta


def import_minari(dataset_id: str, adapter_name: str, *,
                  progress=lambda: None) -> tuple[object, Iterator]:
    """(header, episodes) of a local Minari dataset, its observations made B states by the
    adapter ``adapter_name`` (given by the user: importing an adapter runs code)."""
    from ..episodes.model import Episode, StepRecord, make_end
    from ..episodes.writer import new_header

    minari = _minari()
    try:
        dataset = minari.load_dataset(dataset_id)
    except (FileNotFoundError, ValueError) as exc:
        raise InputError(f"cannot load the Minari dataset {dataset_id}: {exc}",
                         hint="list the local ones with `minari list local`") from None
    from ..live.adapter import load_adapter

    adapter = load_adapter(adapter_name)
    env = _make_env(adapter, None, f"--env {adapter_name}")
    meta = _provenance(dataset.storage.metadata.get("tracecheck"), dataset_id)
    header = new_header("imported-minari", environment=adapter.name,
                        environment_id=adapter.env_id, model_name=adapter.model_name or None,
                        variables=list(adapter.variables), actions=list(adapter.actions),
                        agent_id=meta.get("agent"), shield_name=meta.get("shield"),
                        shield_sha256=meta.get("shield_sha256"))

    def episodes():
        seeds = {int(m["id"]): m.get("seed")  # every episode's, read once
                 for m in dataset.storage.get_episode_metadata(dataset.episode_indices)}
        for data in dataset.iterate_episodes():
            observer = adapter.observer(env)
            where = f"{dataset_id}, episode {data.id}"
            n = len(data.actions)
            steps = []
            _check_lengths(data, n, where)
            for k in range(n + 1):
                crashed = bool(k == n and n and data.terminations[-1])
                reward = 0.0 if k == 0 else float(data.rewards[k - 1])
                if not np.isfinite(reward):
                    raise InputError(f"{where}, step {k}: the reward is {reward}")
                try:
                    state = observer.state(data.observations[k], {"crashed": crashed}, reward,
                                           initial=k == 0)
                except Exception as exc:
                    raise InputError(f"{where}, step {k}: the {adapter.name} adapter cannot "
                                     f"read the observation: {exc}") from None
                action = None
                if k:
                    action = adapter.actions[_action_index(data.actions[k - 1],
                                                           len(adapter.actions),
                                                           f"{where}, step {k}")]
                steps.append(StepRecord(step=k, time=k * adapter.seconds_per_step,
                                        action=action, state=state, reward=reward,
                                        crashed=crashed, **_shield_infos(data.infos, k, n,
                                                                         adapter.actions)))
            steps = tuple(steps)
            reason = ("time-limit" if n and data.truncations[-1] else
                      "crashed" if steps[-1].crashed else "end-of-trace")
            seed = seeds.get(int(data.id))
            yield Episode(id=int(data.id), steps=steps, end=make_end(steps, reason),
                          seed=None if seed is None else int(seed),
                          origin=f"minari:{dataset_id}")
            progress()

    return header, episodes()
