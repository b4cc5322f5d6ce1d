"""Importing a Minari dataset (``pip install 'tracecheck[minari]'``).

A Minari dataset's episodes, given an adapter that turns observations into B states, become a
run file that replay, diff and stats read like a recording; the infos tracecheck's export
writes (:mod:`tracecheck.interop.minari`), where a dataset has them, come back as the steps'
allowed actions, preferred action, action values and deadlock flag, so a run exported and
imported again replays exactly like the original.

The dataset is checked field by field before Minari reads it — metadata types and sizes,
spaces, every episode's seed and the sizes of its arrays (before any is allocated), the types
of rewards and flags, finite observations in the dataset's observation space, tracecheck's
infos well-formed, the declared counts of episodes and steps (:mod:`.minari_checks`) — and
what it cannot take exactly is refused, naming the dataset, the episode and the step or the
metadata field. Export, dataset ids and the datasets folder: :mod:`tracecheck.interop.minari`.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Iterator, Optional

import numpy as np

from ..errors import InputError, TracecheckError
from ..inputs import read_text
from .minari import dataset_folder, make_env, minari_package
from .minari_checks import check_counts, check_episode_steps, check_infos, check_observations

__all__ = ["import_minari"]

#: the most bytes the arrays of one episode may take once read (a dataset claiming more is
#: refused before anything is allocated)
MAX_EPISODE_BYTES = 1 << 30
#: the most elements a dataset's observation or action space may have
MAX_SPACE_ELEMENTS = 1 << 24
#: seeds as a run file stores them and Gymnasium's reset takes them
MAX_SEED = 2**63 - 1


def _action_index(value, count: int, where: str, start: int = 0) -> int:
    """A discrete action: one integer in start … start+count-1 (a ``Discrete(n, start)``
    space's), as its index 0 … count-1 (a float, a vector or a value out of range is
    refused, never rounded or cut to fit)."""
    a = np.asarray(value)
    if a.size != 1 or a.dtype.kind not in "iu":
        raise InputError(f"{where}: the action {a.tolist()!r} is not an action index; the "
                         f"adapter has {count} discrete actions")
    index = int(a.reshape(-1)[0]) - start
    if not 0 <= index < count:
        raise InputError(f"{where}: action {index + start} is not one of the adapter's "
                         f"{count} actions" + (f" ({start} … {start + count - 1})"
                                               if start else ""))
    return index


def _check_lengths(data, n: int, where: str) -> None:
    """n actions, rewards, terminations and truncations; n + 1 observations."""
    for name, want in (("rewards", n), ("terminations", n), ("truncations", n),
                       ("observations", n + 1)):
        try:
            got = _steps(getattr(data, name), f"{where}: the {name}")
        except TypeError:  # a scalar
            raise InputError(f"{where}: the {name} are one value, not one per step") from None
        if got != want:
            raise InputError(f"{where}: {got} {name} for {n} actions (want {want})")


def _steps(values, what: str) -> int:
    """How many steps ``values`` has: a Dict or Tuple space's observations, each of its
    parts' (the same for all)."""
    parts = list(values.values()) if isinstance(values, dict) else \
        list(values) if isinstance(values, tuple) else None
    if parts is None:
        return len(values)
    counts = {_steps(part, what) for part in parts}
    if len(counts) != 1:
        raise InputError(f"{what} have parts of {' and '.join(map(str, sorted(counts)))} "
                         "steps, not one number of steps" if counts else f"{what} have no part")
    return counts.pop()


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

    minari = minari_package()
    seeds = _check_dataset(dataset_folder(dataset_id) / "data", dataset_id)
    try:
        dataset = minari.load_dataset(dataset_id)
    except Exception as exc:  # noqa: BLE001 - what Minari still refuses after our checks
        raise InputError(f"cannot load the Minari dataset {dataset_id}: {exc}",
                         hint="list the local ones with `minari list local`") from None
    from ..live.adapter import load_adapter

    adapter = load_adapter(adapter_name)
    env = make_env(adapter, None, f"--env {adapter_name}")
    meta = _provenance(dataset.storage.metadata.get("tracecheck"), dataset_id)
    header = new_header("imported-minari", environment=adapter.name,
                        environment_id=adapter.env_id, model_name=adapter.model_name or None,
                        variables=list(adapter.variables), actions=list(adapter.actions),
                        agent_id=meta.get("agent"), shield_name=meta.get("shield"),
                        shield_sha256=meta.get("shield_sha256"))

    from ..b.conversion import convert_state
    from ..checking.shield import typing_machine
    from ..live.wrapper import discrete_start

    typing = typing_machine(adapter)  # the adapter's states made B values by its shield's types
    #: a Discrete(n, start) space's actions are start … start+n-1: the adapter's 0 … n-1
    start = discrete_start(dataset.action_space)

    def episodes():
        from ..episodes.codec import encode_state

        for index, data in _episode_data(dataset, dataset_id):
            where = f"{dataset_id}, episode {index}"
            stored = _stored(data.infos, len(data.actions), adapter, where)
            observer = None
            if stored is None:  # a dataset of other origin: the adapter reads observations
                env.reset(seed=seeds[index])  # of the environment as it made that episode
                observer = adapter.observer(env)
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
                reward = 0.0 if k == 0 else float(rewards[k - 1])
                crashed = _crashed(adapter, data, stored, k, n, reward, where)
                try:
                    state = stored[0][k] if stored is not None else convert_state(
                        observer.state(_observation_at(data.observations, k),
                                       {"crashed": crashed}, reward,
                                       initial=k == 0),
                        typing.state_types() if typing is not None else None,
                        where=f"state() of the adapter {adapter.name}")
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
                                                           f"{where}, step {k}", start)]
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


def _stored(infos, n: int, adapter, where: str):
    """(states, crash flags) tracecheck's export stored in ``infos`` (``b_state``, JSON per
    observation; ``crashed``, where written) — what the episode was, not what the adapter
    would read from the observations again; None for a dataset without them."""
    from ..episodes.codec import decode_state

    texts = infos.get("b_state") if isinstance(infos, dict) else None
    if texts is None or np.shape(texts) != (n + 1,):
        return None
    states = []
    for k, text in enumerate(texts):
        here = f"{where}, step {k}: its infos/b_state"
        try:
            data = json.loads(text.decode() if isinstance(text, bytes) else str(text))
        except (ValueError, UnicodeDecodeError):
            raise InputError(f"{here} is not JSON") from None
        if not isinstance(data, dict):
            raise InputError(f"{here} is not a JSON object of the state's variables")
        state = decode_state(data, where=here)
        missing = [v for v in adapter.variables if v not in state]
        if missing:
            raise InputError(f"{here} gives no value for {missing[0]}, a variable of "
                             f"{adapter.name}", hint="import it with the environment it was "
                                                     "exported from (--env)")
        states.append(state)
    flags = infos.get("crashed")
    crashed = [bool(f) for f in np.asarray(flags)] if flags is not None and \
        np.shape(flags) == (n + 1,) and np.asarray(flags).dtype == bool else None
    return states, crashed


def _crashed(adapter, data, stored, k: int, n: int, reward: float, where: str) -> bool:
    """Whether step ``k`` crashed: as stored by tracecheck's export; else, at an episode's
    last step if it terminated, as the adapter judges it (a goal reached terminates too)."""
    if stored is not None and stored[1] is not None:
        return stored[1][k]
    if not (k == n and n and data.terminations[-1]):
        return False
    try:
        return bool(adapter.crashed(_observation_at(data.observations, k), reward, True,
                                    {"crashed": True}))
    except Exception as exc:  # noqa: BLE001 - the user's adapter: said with the place
        raise InputError(f"{where}, step {k}: the {adapter.name} adapter cannot judge whether "
                         f"the episode crashed: {type(exc).__name__}: {exc}") from None


def _observation_at(observations, k: int):
    if isinstance(observations, dict):
        return {key: _observation_at(v, k) for key, v in observations.items()}
    if isinstance(observations, (tuple, list)):
        return type(observations)(_observation_at(v, k) for v in observations)
    return observations[k]


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
