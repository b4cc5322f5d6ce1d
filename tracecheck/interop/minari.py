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

Dataset ids are checked before Minari sees them: ``(namespace/)name-vN`` (Minari's own form,
with the version it needs; letters, digits, ``-`` and ``_``), so no id can name a folder
outside ``MINARI_DATASETS_PATH``. Export writes into a hidden folder in that path and moves
the finished dataset into place, so a failure leaves nothing behind. Import checks the
dataset field by field before Minari reads it — metadata types and sizes, spaces, every
episode's seed and the sizes of its arrays (before any is allocated), the types of rewards
and flags, finite observations in the dataset's observation space, tracecheck's infos
well-formed, the declared counts of episodes and steps (:mod:`.minari_checks`) — and refuses
what it cannot take exactly, naming the dataset, the episode and the step or the metadata
field.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import tempfile
import warnings
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Iterator, Optional

import numpy as np

from ..errors import InputError, TracecheckError, read_text
from .minari_checks import check_counts, check_episode_steps, check_infos, check_observations

__all__ = ["export_minari", "import_minari", "check_dataset_id", "datasets_root",
           "dataset_folder"]

#: Minari's ``(namespace/)name-vN`` (its DATASET_ID_RE), with the version it needs and no
#: empty folder: no ``.``, ``..``, leading ``/`` — nothing that leaves the datasets folder
_ID = re.compile(r"(?:(?P<namespace>[-\w]+(?:/[-\w]+)*)/)?[-\w]+-v\d+")
#: the most bytes the arrays of one episode may take once read (a dataset claiming more is
#: refused before anything is allocated)
MAX_EPISODE_BYTES = 1 << 30
#: the most elements a dataset's observation or action space may have
MAX_SPACE_ELEMENTS = 1 << 24
#: seeds as a run file stores them and Gymnasium's reset takes them
MAX_SEED = 2**63 - 1


def check_dataset_id(dataset_id: str) -> str:
    """``dataset_id`` if it is a Minari id naming a folder inside the datasets folder."""
    match = _ID.fullmatch(dataset_id)
    if match is None or len(match.group("namespace") or "--") < 2 or len(dataset_id) > 1000:
        raise InputError(f"{dataset_id!r} is not a Minari dataset id: write (namespace/)name-vN "
                         "with letters, digits, - and _ (a namespace of 2 characters or more), "
                         "e.g. tracecheck/highway/paper-v0")
    return dataset_id


def datasets_root() -> Path:
    """The local Minari datasets folder (``MINARI_DATASETS_PATH``, default
    ``~/.minari/datasets``), made if missing; an :class:`InputError` if it cannot be."""
    env = os.environ.get("MINARI_DATASETS_PATH")
    if env == "":
        raise InputError("MINARI_DATASETS_PATH is set but empty; give it a folder")
    root = Path(env) if env is not None else Path.home() / ".minari" / "datasets"
    what = f"the Minari datasets folder {root}" + (" (MINARI_DATASETS_PATH)" if env else "")
    if root.exists() and not root.is_dir():
        raise InputError(f"{what} is a file, not a folder")
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot use {what}: {exc.strerror or exc}") from None
    return root


def dataset_folder(dataset_id: str) -> Path:
    """The folder of the local dataset ``dataset_id`` (its id checked first): the input of
    ``import minari``, which no output may be or be inside."""
    check_dataset_id(dataset_id)  # first: a bad id makes no folder
    return datasets_root() / dataset_id


@contextmanager
def _datasets_path(path: Path):
    """Minari's datasets folder is ``path`` for the time being."""
    old = os.environ.get("MINARI_DATASETS_PATH")
    os.environ["MINARI_DATASETS_PATH"] = str(path)
    try:
        yield
    finally:
        if old is None:
            os.environ.pop("MINARI_DATASETS_PATH", None)
        else:
            os.environ["MINARI_DATASETS_PATH"] = old


def _minari():
    try:
        import minari
    except ImportError:
        raise InputError("Minari is not installed", hint="pip install 'tracecheck[minari]'") \
            from None
    return minari


def _recorded_name(header) -> str:
    """The environment a run was recorded in, as ``--env`` names it where it can be told."""
    from ..live.adapter import adapters

    if header.environment:
        return header.environment
    return next((a.name for a in adapters()
                 if a.adapter is not None and a.adapter.env_id == header.environment_id),
                header.environment_id)


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
    """The adapter's environment, with ``config`` (a run header's) on its defaults."""
    from ..live.adapter import MakeError

    try:
        settings = adapter.config(config or {})
    except TracecheckError as exc:  # the run header's settings, not an option of the user's
        said = f"its environment_config does not fit {adapter.name}: " if config else ""
        raise InputError(f"{what}: {said}{exc.message}", hint=None if config else exc.hint) \
            from exc
    try:
        return adapter.make_env(settings)
    except MakeError as exc:
        raise InputError(f"{what}: {exc.message}", hint=exc.hint) from exc.__cause__
    except TracecheckError as exc:
        raise InputError(f"{what}: {exc.message}", hint=exc.hint) from exc
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

    check_dataset_id(dataset_id)
    root = datasets_root()
    _refuse_taken(root, dataset_id)
    result = read_run(run)
    header = result.header
    if not result.episodes:
        raise InputError(f"{run} holds no complete episode")
    adapter = load_adapter(env) if env else _recorded_adapter(header, run)
    recorded = header.environment or header.environment_id
    if env and recorded and adapter.name != header.environment and \
            adapter.env_id != header.environment_id:
        name = _recorded_name(header)
        raise InputError(f"{run} was recorded in {name}, not {adapter.name}: its observations "
                         "are not that environment's",
                         hint=f"give --env {name} (or the package.module:Class of its "
                              "adapter), or leave --env out")
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
    description = (f"Episodes of agent {header.agent_id or 'unknown'} under the B shield "
                   f"{shield} (sha256 {header.shield_sha256 or '-'}), recorded by tracecheck. "
                   f"infos: allowed (shield mask over {', '.join(actions)}), intervened, "
                   "deadlock, b_state (JSON).")
    try:
        work = Path(tempfile.mkdtemp(prefix=".tracecheck-", dir=root))  # hidden: not listed
    except OSError as exc:
        raise InputError(f"cannot write in the Minari datasets folder {root}: "
                         f"{exc.strerror or exc}") from None
    try:
        with _datasets_path(work), warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # its advice to add an e-mail address
            try:
                dataset = minari.create_dataset_from_buffers(
                    dataset_id=dataset_id, buffer=buffers, env=made.spec,
                    algorithm_name=header.agent_id or "unknown", author="tracecheck",
                    description=description, action_space=made.action_space,
                    observation_space=made.observation_space, data_format="hdf5")
                dataset.storage.update_metadata({"tracecheck": json.dumps(about)})
            except OSError as exc:
                raise InputError(f"cannot write the Minari dataset {dataset_id} in {root}: "
                                 f"{exc.strerror or exc}") from None
            except Exception as exc:  # noqa: BLE001 - Minari's own checks and failures
                raise InputError(f"cannot create the Minari dataset {dataset_id}: "
                                 f"{type(exc).__name__}: {exc}") from None
        _move_into_place(work, root, dataset_id)
    finally:
        shutil.rmtree(work, ignore_errors=True)
        made.close()
    return minari.load_dataset(dataset_id)


def _refuse_taken(root: Path, dataset_id: str) -> None:
    target = root / dataset_id
    if os.path.lexists(target):
        raise InputError(f"cannot create the Minari dataset {dataset_id}: it exists ({target})",
                         hint="give another name or version, e.g. -v1")
    for parent in target.parents:
        if len(parent.parts) <= len(root.parts):
            break
        if os.path.lexists(parent) and not parent.is_dir():
            raise InputError(f"cannot create the Minari dataset {dataset_id}: {parent} is a "
                             "file, not a namespace folder")


def _move_into_place(work: Path, root: Path, dataset_id: str) -> None:
    """Move the dataset written under ``work`` to ``root``: the first folder of its id that
    ``root`` lacks is renamed there whole (namespace metadata included), in one step."""
    parts = dataset_id.split("/")
    _refuse_taken(root, dataset_id)
    for i in range(1, len(parts) + 1):
        dest = root.joinpath(*parts[:i])
        if not os.path.lexists(dest):
            try:
                os.rename(work.joinpath(*parts[:i]), dest)
            except OSError as exc:
                raise InputError(f"cannot write the Minari dataset {dataset_id} in {root}: "
                                 f"{exc.strerror or exc}") from None
            return


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
        try:
            got = len(getattr(data, name))
        except TypeError:  # a scalar
            raise InputError(f"{where}: the {name} are one value, not one per step") from None
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
    seeds = _check_dataset(dataset_folder(dataset_id) / "data", dataset_id)
    try:
        dataset = minari.load_dataset(dataset_id)
    except Exception as exc:  # noqa: BLE001 - what Minari still refuses after our checks
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
        from ..episodes.codec import encode_state

        for index, data in _episode_data(dataset, dataset_id):
            observer = adapter.observer(env)
            where = f"{dataset_id}, episode {index}"
            n = len(data.actions)
            steps = []
            _check_lengths(data, n, where)
            _check_flags(data, where)
            _check_finite(data.observations, n, where)
            check_observations(data.observations, dataset.observation_space, n, where)
            check_infos(data.infos, n, len(adapter.actions), where)
            rewards = np.asarray(data.rewards[:n], dtype=float)
            bad = np.flatnonzero(~np.isfinite(rewards))  # checked at once, not step by step
            if bad.size:
                raise InputError(f"{where}, step {bad[0] + 1}: the reward is {rewards[bad[0]]}")
            for k in range(n + 1):
                crashed = bool(k == n and n and data.terminations[-1])
                reward = 0.0 if k == 0 else float(rewards[k - 1])
                try:
                    state = observer.state(data.observations[k], {"crashed": crashed}, reward,
                                           initial=k == 0)
                    encode_state(state)  # a value a run file cannot hold (NaN), said here
                except TracecheckError as exc:
                    raise InputError(f"{where}, step {k}: {exc.message}") from exc
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
            yield Episode(id=index, steps=steps, end=make_end(steps, reason),
                          seed=seeds[index], origin=f"minari:{dataset_id}")
            progress()

    return header, episodes()


def _episode_data(dataset, dataset_id: str):
    """(index, EpisodeData) of every episode, in order; the index is the one of the episode's
    group (``episode_N``), as Minari reads it."""
    episodes = iter(dataset.iterate_episodes())
    for index in range(int(dataset.total_episodes)):
        try:
            data = next(episodes)
        except Exception as exc:  # noqa: BLE001 - Minari's decoding of what we checked
            raise InputError(f"{dataset_id}, episode {index}: Minari cannot read it: "
                             f"{type(exc).__name__}: {exc}") from None
        yield index, data


def _check_flags(data, where: str) -> None:
    for name in ("terminations", "truncations"):
        flags = np.asarray(getattr(data, name))
        if flags.dtype.kind != "b" and not (flags.dtype.kind in "iu" and
                                            np.isin(flags, (0, 1)).all()):
            raise InputError(f"{where}: the {name} are {flags.dtype} values, not true/false")


def _check_finite(observations, n: int, where: str) -> None:
    if isinstance(observations, np.ndarray) and observations.dtype.kind == "f" \
            and len(observations) == n + 1:
        bad = ~np.isfinite(observations.reshape(n + 1, -1)).all(axis=1)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise InputError(f"{where}, step {k}: the observation holds "
                             f"{'NaN' if np.isnan(observations[k]).any() else 'infinity'}; "
                             "B has no NaN or infinity")


_SPACES = ("Box", "Discrete", "MultiDiscrete", "MultiBinary", "Dict", "Tuple", "Text")


def _count(value, what: str) -> int:
    """The product of a shape (a list of non-negative integers, or one)."""
    dims = value if isinstance(value, list) else [value]
    if not dims or not all(type(d) is int and d >= 0 for d in dims) or len(dims) > 32:
        raise InputError(f"{what}: the shape {value!r} is not a list of sizes")
    total = 1
    for d in dims:
        total = min(total * d, MAX_SPACE_ELEMENTS + 1)
    return total


def _space_size(d, what: str, depth: int = 0) -> int:
    """The elements of a serialized Gymnasium space (as Minari writes it), checked before
    Gymnasium builds it (a Box of shape [10^12] would be allocated)."""
    if depth > 32 or not isinstance(d, dict) or d.get("type") not in _SPACES:
        kind = d.get("type") if isinstance(d, dict) else d
        raise InputError(f"{what} is {str(kind)[:80]!r}, not a space Minari writes "
                         f"({', '.join(_SPACES)})")
    kind = d["type"]
    if kind == "Box":
        return _count(d.get("shape"), what)
    if kind == "MultiBinary":
        return _count(d.get("n"), what)
    if kind in ("Dict", "Tuple"):
        subs = d.get("subspaces")
        subs = subs.values() if kind == "Dict" and isinstance(subs, dict) else subs
        if not isinstance(subs, (list, type({}.values()))):
            raise InputError(f"{what}: a {kind} space without its subspaces")
        return sum(_space_size(x, what, depth + 1) for x in subs)
    if kind == "Discrete" and not (type(d.get("n")) is int and type(d.get("start", 0)) is int
                                   and d["n"] >= 1):
        raise InputError(f"{what}: a Discrete space needs integers n >= 1 and start")
    if kind == "Text" and not (type(d.get("max_length")) is int
                               and 0 <= d["max_length"] <= MAX_SPACE_ELEMENTS):
        raise InputError(f"{what}: a Text space needs a max_length up to "
                         f"{MAX_SPACE_ELEMENTS:,}")
    return 1


def _field(meta: dict, name: str, types, dataset_id: str, *, required: bool = True):
    value = meta.get(name)
    if value is None and not required:
        return None
    if value is None or not isinstance(value, types) or (types is int and isinstance(value, bool)):
        want = " or ".join(t.__name__ for t in (types if isinstance(types, tuple) else (types,)))
        got = "missing" if name not in meta else repr(value)[:80]
        raise InputError(f"{dataset_id}: the metadata field {name} is {got}, not a "
                         f"{want.replace('str', 'string').replace('int', 'integer')}")
    return value


def _check_metadata(data: Path, dataset_id: str) -> dict:
    """The dataset's metadata.json, every field tracecheck or Minari reads checked."""
    from gymnasium.envs.registration import EnvSpec
    from minari.serialization import deserialize_space

    if not (data / "metadata.json").is_file():
        raise InputError(f"cannot load the Minari dataset {dataset_id}: there is none at "
                         f"{data.parent}", hint="list the local ones with `minari list local`")
    try:
        meta = json.loads(read_text(data / "metadata.json", "Minari metadata file"))
    except ValueError as exc:
        raise InputError(f"{dataset_id}: its metadata.json is not JSON: {exc}") from None
    if not isinstance(meta, dict):
        raise InputError(f"{dataset_id}: its metadata.json is not a JSON object")
    _field(meta, "dataset_id", str, dataset_id)
    _field(meta, "minari_version", str, dataset_id)
    if _field(meta, "data_format", str, dataset_id) != "hdf5":
        raise InputError(f"{dataset_id}: it is stored as {meta['data_format'][:40]!r}; "
                         "tracecheck imports Minari's hdf5 format (its default)")
    for name in ("total_episodes", "total_steps"):
        if _field(meta, name, int, dataset_id) < 0:
            raise InputError(f"{dataset_id}: the metadata field {name} is {meta[name]}")
    _field(meta, "jpeg_encoding", bool, dataset_id, required=False)
    for name in ("author", "author_email", "combined_datasets"):
        value = _field(meta, name, list, dataset_id, required=False)
        if value is not None and not all(isinstance(v, str) for v in value):
            raise InputError(f"{dataset_id}: the metadata field {name} is not a list of "
                             "strings")
    for name in ("observation_space", "action_space"):
        what = f"{dataset_id}: the metadata field {name}"
        text = _field(meta, name, str, dataset_id)
        try:
            space = json.loads(text)
        except ValueError:
            raise InputError(f"{what} is not a serialized space (JSON)") from None
        if _space_size(space, what) > MAX_SPACE_ELEMENTS:
            raise InputError(f"{what} has more than {MAX_SPACE_ELEMENTS:,} elements")
        try:
            deserialize_space(space)
        except Exception as exc:  # noqa: BLE001 - Gymnasium refusing the space's values
            raise InputError(f"{what} is not a valid space: {type(exc).__name__}: "
                             f"{str(exc)[:200]}") from None
    for name in ("env_spec", "eval_env_spec"):
        text = _field(meta, name, str, dataset_id, required=False)
        if text is not None:
            try:
                EnvSpec.from_json(text)
            except Exception as exc:  # noqa: BLE001 - not an environment spec
                raise InputError(f"{dataset_id}: the metadata field {name} is not a "
                                 f"Gymnasium environment spec: {str(exc)[:200]}") from None
    return meta


def _seed(value: Any, where: str) -> Optional[int]:
    """An episode's seed, exactly: an integer 0 … 2^63 - 1 (never a rounded float)."""
    if isinstance(value, np.ndarray) and value.shape == ():
        value = value[()]
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        shown = value.item() if isinstance(value, np.generic) else value
        raise InputError(f"{where}: the seed {repr(shown)[:80]} is not an integer (a seed "
                         "is never rounded)")
    if not 0 <= int(value) <= MAX_SEED:
        raise InputError(f"{where}: the seed {int(value)} is out of range: a seed is 0 … "
                         "2^63 - 1 (what Gymnasium takes and a run file stores)")
    return int(value)


def _check_dataset(data: Path, dataset_id: str) -> list[Optional[int]]:
    """Check a local hdf5 dataset before Minari reads it; the seed of each episode, by the
    index of its group ``episode_N`` (Minari's episode id; an ``id`` attribute that differs
    is not used)."""
    import h5py

    meta = _check_metadata(data, dataset_id)
    try:
        file = h5py.File(data / "main_data.hdf5", "r")
    except OSError as exc:
        raise InputError(f"{dataset_id}: cannot read its main_data.hdf5: {exc}") from None
    seeds, steps = [], 0
    with file:
        total = meta["total_episodes"]
        if total > len(file):
            raise InputError(f"{dataset_id}: the metadata field total_episodes says {total}, "
                             f"the data file holds {len(file)} group(s)")
        for i in range(total):
            where = f"{dataset_id}, episode {i}"
            group = file.get(f"episode_{i}")
            if not isinstance(group, h5py.Group):
                raise InputError(f"{where}: the data file has no group episode_{i}")
            attrs = dict(group.attrs)
            seeds.append(_seed(attrs["seed"], where) if "seed" in attrs else None)
            _check_episode(group, where)
            steps += check_episode_steps(group, where)
        check_counts(file, meta, steps, dataset_id)
    return seeds


def _check_episode(group, where: str) -> None:
    """Its arrays exist, and their sizes (read from the file's headers, nothing allocated)
    stay within :data:`MAX_EPISODE_BYTES`; rewards are numbers, flags true/false."""
    import h5py

    for name in ("observations", "actions", "rewards", "terminations", "truncations"):
        if name not in group:
            raise InputError(f"{where}: it has no {name}")
        if isinstance(group[name], h5py.Dataset) and group[name].ndim == 0:
            raise InputError(f"{where}: the {name} are one value, not one per step")
    for name, kinds, what in (("rewards", "biuf", "numbers"), ("terminations", "biu", "flags"),
                              ("truncations", "biu", "flags")):
        item = group[name]
        if not isinstance(item, h5py.Dataset) or item.ndim != 1 or item.dtype.kind not in kinds:
            shape = getattr(item, "shape", None)
            kind = getattr(item, "dtype", "a group")
            raise InputError(f"{where}: the {name} are {kind} of shape {shape}, not {what}")
    sizes = []

    def add(_, item):
        if isinstance(item, h5py.Dataset):
            sizes.append(int(np.prod(item.shape, dtype=object)) * max(item.dtype.itemsize, 1))

    group.visititems(add)
    if sum(sizes) > MAX_EPISODE_BYTES:
        raise InputError(f"{where}: its arrays would take {sum(sizes):,} bytes; tracecheck "
                         f"reads at most {MAX_EPISODE_BYTES:,} per episode")
