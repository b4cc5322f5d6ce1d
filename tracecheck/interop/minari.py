"""Minari datasets (Farama's offline-RL standard; ``pip install 'tracecheck[minari]'``): a run
exported as one, and what export and import share (dataset ids, the datasets folder, the
environment).

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

Dataset ids are checked before Minari sees them: ``(namespace/)name-vN`` (Minari's own form,
with the version it needs; letters, digits, ``-`` and ``_``), so no id can name a folder
outside ``MINARI_DATASETS_PATH``. Export writes into a hidden folder in that path and moves
the finished dataset into place, so a failure leaves nothing behind. Import:
:mod:`tracecheck.interop.minari_import`.
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
from typing import Optional

import numpy as np

from ..errors import InputError, TracecheckError

__all__ = ["export_minari", "check_dataset_id", "datasets_root", "dataset_folder",
           "minari_package", "make_env"]

#: Minari's ``(namespace/)name-vN`` (its DATASET_ID_RE), with the version it needs and no
#: empty folder: no ``.``, ``..``, leading ``/`` — nothing that leaves the datasets folder
_ID = re.compile(r"(?:(?P<namespace>[-\w]+(?:/[-\w]+)*)/)?[-\w]+-v\d+")


def check_dataset_id(dataset_id: str) -> str:
    """``dataset_id`` if it is a Minari id naming a folder inside the datasets folder."""
    match = _ID.fullmatch(dataset_id)
    if match is None or len(match.group("namespace") or "--") < 2 or len(dataset_id) > 1000:
        raise InputError(f"{dataset_id!r} is not a Minari dataset id: write (namespace/)name-vN "
                         "with letters, digits, - and _ (a namespace of 2 characters or more), "
                         "e.g. tracecheck/corridor/base-v0")
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


def minari_package():
    """The minari package, or an error saying how to install it."""
    try:
        import minari
    except ImportError:
        raise InputError("Minari is not installed", hint="pip install 'tracecheck[minari]'") \
            from None
    return minari


def _recorded_name(header) -> str:
    """The environment a run was recorded in, as ``--env`` names it where it can be told."""
    from ..live.adapter import adapters_for_env_id

    if header.environment:
        return header.environment
    return next((a.name for a in adapters_for_env_id(header.environment_id)),
                header.environment_id)


def _recorded_adapter(header, run: Path):
    """The installed adapter a run file names (by name, or for files from before adapters
    were named, by environment id) — never a module named inside the file."""
    from ..live.adapter import adapters_for_env_id, get_adapter

    name = header.environment
    if not name and header.environment_id:
        name = next((a.name for a in adapters_for_env_id(header.environment_id)), None)
    if not name:
        raise InputError(f"{run} names no environment adapter; Minari needs the environment's "
                         "spaces", hint="give the adapter with --env")
    return get_adapter(name)


def make_env(adapter, config: Optional[dict], what: str):
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


def _composite(space) -> bool:
    from gymnasium import spaces

    return isinstance(space, (spaces.Dict, spaces.Tuple))


def _unflattened(value: np.ndarray, space, where: str):
    """A Dict or Tuple observation from the numbers it was recorded as (gymnasium's
    flatten: see :func:`tracecheck.live.rollout.flattening`)."""
    from gymnasium import spaces

    flat = value.reshape(-1)
    if flat.size != spaces.flatdim(space):
        raise InputError(f"{where}: an observation of {flat.size} number(s) does not fit the "
                         f"environment's {space}, {spaces.flatdim(space)} flattened (was it "
                         "recorded with another configuration?)")
    hint = "was it recorded with another environment or configuration?"
    try:  # gymnasium casts as it unflattens (0.25 to a uint8 0): flattened again, the same
        restored = spaces.unflatten(space, flat)
        differs = np.flatnonzero(np.asarray(spaces.flatten(space, restored),
                                            dtype=np.float64) != flat)
    except Exception:  # noqa: BLE001 - gymnasium's: a one-hot part with no 1 in it
        restored = differs = None
    if restored is None or not space.contains(restored):
        raise InputError(f"{where}: the observation is not a value of the environment's "
                         f"observation space {str(space)[:200]}", hint=hint)
    if differs.size:
        at = int(differs[0])
        raise InputError(f"{where}: the observation's number {flat[at].item()!r} at index "
                         f"{at} of its {flat.size} (as gymnasium flattens the environment's "
                         f"{str(space)[:200]}) is not a value that space holds there",
                         hint=hint)
    return restored


def _stacked(obs: list, space):
    """An episode's observations of a Dict or Tuple ``space`` as Minari takes them: each
    part's together (nested as the space is)."""
    from gymnasium import spaces

    if isinstance(space, spaces.Dict):
        return {k: _stacked([o[k] for o in obs], sub) for k, sub in space.spaces.items()}
    if isinstance(space, spaces.Tuple):
        return tuple(_stacked([o[i] for o in obs], sub) for i, sub in enumerate(space.spaces))
    return np.asarray(obs)  # a part's: one row per step


def _observation(rows, space, where: str):
    if rows is None:
        raise InputError(f"{where} has no observation (imported traces record none); a Minari "
                         "dataset needs the observations of a recording")
    value = np.asarray(rows, dtype=np.float64)
    if _composite(space):
        return _unflattened(value, space, where)
    if space.shape == ():
        if value.size != 1 or not float(value.reshape(-1)[0]).is_integer():
            raise InputError(f"{where}: the observation {value.tolist()!r} is not one of "
                             f"{space}")
        return np.asarray(value.reshape(-1)[0]).astype(space.dtype)
    if value.size != int(np.prod(space.shape)):
        raise InputError(f"{where}: an observation of shape {value.shape} does not fit the "
                         f"environment's {space} (was it recorded with another configuration?)")
    value = value.reshape(space.shape)
    cast = value.astype(space.dtype)
    exact = cast.astype(np.float64) == value
    inside = exact & (cast >= space.low) & (cast <= space.high) if hasattr(space, "low") \
        else exact
    if not inside.all():  # 0.25 under a uint8 Box became 0: written, every value would be
        at = tuple(int(i) for i in np.argwhere(~inside)[0])
        raise InputError(f"{where}: the observation's value {value[at]!r} at index {list(at)} "
                         f"is not a value of the environment's observation space {space}",
                         hint="the environment's observations do not fit the space it "
                              "declares (floats in [0, 1] under a uint8 Box?): a Minari "
                              "dataset stores them in that space's type, so declare the "
                              "space the observations have")
    return cast


def export_minari(run: Path, dataset_id: str, *, env: Optional[str] = None,
                  progress=lambda: None, salvage: bool = False):
    """Write the episodes of ``run`` as the local Minari dataset ``dataset_id``; the dataset.
    ``env``: the adapter as the user names it (default: the installed one the file names);
    ``salvage``: as :func:`~tracecheck.episodes.reader.read_run`."""
    from ..live.adapter import load_adapter
    from ..live.wrapper import discrete_start
    from ..episodes.codec import encode_state
    from ..episodes.reader import read_run
    from .common import refuse_continuous

    minari = minari_package()
    from minari.data_collector.episode_buffer import EpisodeBuffer

    check_dataset_id(dataset_id)
    root = datasets_root()
    _refuse_taken(root, dataset_id)
    result = read_run(run, salvage=salvage)
    refuse_continuous(result.episodes, "tracecheck's Minari export (it writes action indexes)")
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
    made = make_env(adapter, header.environment_config, str(run))
    actions = list(adapter.actions)
    #: the actions as the environment takes them: a Discrete(n, start) space's start + index
    start = discrete_start(made.action_space)
    buffers = []
    for ep in result.episodes:
        where = f"{run}, episode {ep.id}"
        obs = [_observation(s.observation, made.observation_space, f"{where}, step {s.step}")
               for s in ep.steps]
        if _composite(made.observation_space):
            obs = _stacked(obs, made.observation_space)
        try:
            acts = [start + actions.index(s.action) for s in ep.steps[1:]]
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
                                      for s in ep.steps], dtype=object),
                 "crashed": np.array([bool(s.crashed) for s in ep.steps], dtype=bool)}
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
            infos=infos, options=dict(ep.reset_options) if ep.reset_options else None))
        progress()
    shield = header.shield_name or "none"
    about = {"run": str(run), "agent": header.agent_id, "agent_sha256": header.agent_sha256,
             "shield": shield, "shield_sha256": header.shield_sha256,
             "environment": adapter.name, "actions": actions}
    description = (f"Episodes of agent {header.agent_id or 'unknown'} under the B shield "
                   f"{shield} (sha256 {header.shield_sha256 or '-'}), recorded by tracecheck. "
                   f"infos: allowed (shield mask over {', '.join(actions)}), intervened, "
                   "deadlock, b_state (JSON), crashed.")
    try:
        work = Path(tempfile.mkdtemp(prefix=".tracecheck-", dir=root))  # hidden: not listed
    except OSError as exc:
        raise InputError(f"cannot write in the Minari datasets folder {root}: "
                         f"{exc.strerror or exc}") from None
    _recoverable(made)
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


def _recoverable(made) -> None:
    """Minari stores how to make the environment again (its spec, wrappers included): a
    wrapper that does not record its arguments cannot be, and Minari's own error says only
    which class it is not."""
    spec = getattr(made, "spec", None)
    bad = [w.name for w in getattr(spec, "additional_wrappers", None) or ()
           if getattr(w, "kwargs", {}) is None]
    if bad:
        raise InputError(f"cannot export: the environment is wrapped in {', '.join(bad)}, which "
                         "does not record its arguments, so Minari cannot store how to make "
                         "the environment again",
                         hint=f"make {bad[0]} also inherit gymnasium.utils.RecordConstructorArgs "
                              f"(and call RecordConstructorArgs.__init__(self, …) in its "
                              "__init__), or have the adapter's make_env wrap the environment "
                              "in a subclass that does; MiniGrid's ImgObsWrapper and "
                              "FullyObsWrapper do not")


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
