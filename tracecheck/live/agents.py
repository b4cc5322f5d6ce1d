"""Agents: load one, rank its actions; the settings and files training uses
(:mod:`tracecheck.live.training` trains them).

Two kinds of agent file: a stable-baselines3 model (``.zip``: DQN, PPO or A2C, or
sb3-contrib's MaskablePPO, for any environment whose spaces match it; SAC, TD3, PPO or A2C
for continuous actions, a ``Box`` action space) and a tabular
Q-learning agent (``.npy``: a table of one row per discrete observation and one column per
action, read with ``allow_pickle=False``).
Loading a stable-baselines3 agent unpickles Python code from the file: tracecheck only
loads agent files from paths the user gives. Only load files you trust; a ``.npy`` table
runs no code.
"""

from __future__ import annotations

import hashlib
import json
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional, Sequence

import numpy as np

from ..errors import InputError

__all__ = ["Agent", "load_agent", "Q_LEARNING", "file_sha256", "card_environment"]

#: Tabular Q-learning: step size, discount, and epsilon-greedy exploration falling linearly
#: from 1 to its floor over the first 80 % of the steps.
Q_LEARNING: dict[str, float] = {"alpha": 0.1, "gamma": 0.99, "epsilon_floor": 0.05,
                                "decay_fraction": 0.8}


def file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


@dataclass
class Agent:
    """A loaded agent: its action values for an observation, best first."""

    path: str
    sha256: str
    algorithm: str
    model: Any
    #: the environment's first observation where it is a ``Discrete(n, start)`` space's:
    #: the agent observes ``o - first`` (a Q-table's row, Stable-Baselines3's one-hot), as
    #: it was trained (:func:`~tracecheck.live.wrapper.indexed`)
    first: int = 0

    @property
    def id(self) -> str:
        return Path(self.path).stem

    @property
    def continuous(self) -> bool:
        """Whether the agent acts with vectors of numbers (a ``Box`` action space)."""
        return self.algorithm in _CONTINUOUS

    def act(self, obs: np.ndarray) -> np.ndarray:
        """A continuous agent's action for ``obs``: its deterministic choice, as floats."""
        if self.first:
            obs = int(obs) - self.first
        action, _ = self.model.predict(obs, deterministic=True)
        return np.asarray(action, dtype=np.float64).reshape(-1)

    def values(self, obs: np.ndarray) -> np.ndarray:
        """One value per action (Q-values for DQN and Q-tables, probabilities for policy
        methods)."""
        if self.first:
            obs = int(obs) - self.first
        if self.algorithm == "q-learning":
            row = int(obs)
            if not 0 <= row < len(self.model):  # numpy would take -1 as the last row
                raise InputError(f"the observation {row} is no row of the Q-table "
                                 f"{Path(self.path).name} ({len(self.model)} rows)",
                                 hint="the environment gave an observation outside its "
                                      "observation space (a reset option or a bug?)")
            return self.model[row].astype(np.float64)
        import torch

        with torch.no_grad():
            tensor, _ = self.model.policy.obs_to_tensor(  # a Dict observation as it is
                obs if isinstance(obs, dict) else np.asarray(obs, dtype=np.float32))
            if self.algorithm == "DQN":
                return self.model.q_net(tensor)[0].cpu().numpy().astype(np.float64)
            dist = self.model.policy.get_distribution(tensor)
            return dist.distribution.probs[0].cpu().numpy().astype(np.float64)


def load_agent(path: str | Path, adapter=None, env=None) -> Agent:
    """Load an agent for an environment (see :func:`_load_agent`), observing as it was
    trained: a ``Discrete(n, start)`` observation as its index (:attr:`Agent.first`)."""
    from .wrapper import discrete_start

    agent = _load_agent(path, adapter, env)
    agent.first = discrete_start(getattr(env, "observation_space", None))
    return agent


def _load_agent(path: str | Path, adapter=None, env=None) -> Agent:
    """Load an agent for an environment (its adapter, and the environment to compare spaces
    with): a Q-table (``.npy``) or a stable-baselines3 DQN, PPO, A2C or MaskablePPO with one
    discrete action per adapter action. Without ``adapter`` the agent is loaded as it is,
    checked against no environment (no environment is assumed).

    A stable-baselines3 file unpickles code: load only files you trust.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"no such agent file: {path}")
    actions = tuple(adapter.actions) if adapter is not None else None
    if path.suffix == ".npy":
        if adapter is not None and adapter.parameters:
            raise InputError(f"{path}: a Q-table chooses among discrete actions; "
                             f"{adapter.name} takes continuous ones",
                             hint="train one: tracecheck train --env … --algorithm sac")
        return _load_table(path, actions, env)
    if not zipfile.is_zipfile(path):
        raise InputError(f"{path} is not a stable-baselines3 agent (not a zip archive) nor "
                         "a Q-table (.npy)")
    import stable_baselines3 as sb3
    import torch

    torch.set_num_threads(1)

    last: Optional[Exception] = None
    saved = _saved_settings(path)
    if _policy_module(path).startswith(("stable_baselines3.sac.", "stable_baselines3.td3.")) \
            or (adapter is not None and adapter.parameters):
        return _load_continuous(path, adapter, env, saved)
    for name, cls in _algorithms(sb3):
        if name in _CLIPPED and "clip_range" not in saved or \
                name == "A2C" and "clip_range" in saved:
            continue  # PPO and A2C files load as each other: PPO's settings tell them apart
        try:
            model = cls.load(path, device="cpu")
        except Exception as exc:  # noqa: BLE001 - try the next algorithm
            last = exc
            continue
        if (name == "MaskablePPO") != type(model.policy).__name__.startswith("Maskable"):
            continue  # a plain PPO file loads as MaskablePPO too (and the other way round)
        space = model.action_space
        if adapter is None:
            if getattr(space, "n", None) is None:
                return _load_continuous(path, adapter, env, saved)
            return Agent(str(path), file_sha256(path), name, model)
        if getattr(space, "n", None) != len(actions):
            raise InputError(f"{path}: the agent has action space {space}; {adapter.name} "
                             f"has {len(actions)} discrete actions ({', '.join(actions)})",
                             hint=_PARAMETERS_HINT.format(op=actions[0])
                             if getattr(space, "shape", None) and getattr(space, "n", None)
                             is None else None)
        _check_observations(path, model.observation_space, adapter, env)
        return Agent(str(path), file_sha256(path), name, model)
    raise InputError(f"{path} is not a stable-baselines3 DQN, PPO or A2C agent nor an "
                     f"sb3-contrib MaskablePPO one ({last})")


#: the algorithms whose files hold ``clip_range`` (A2C's do not)
_CLIPPED = ("PPO", "MaskablePPO")
#: the algorithms of continuous agents (``Agent.algorithm``)
_CONTINUOUS = ("SAC", "TD3", "PPO-continuous", "A2C-continuous")


def _policy_module(path: Path) -> str:
    """The module of the policy class a stable-baselines3 file names (read as JSON text, no
    code run): ``stable_baselines3.sac.policies`` for SAC; "" when it names none."""
    try:
        with zipfile.ZipFile(path) as archive:
            data = json.loads(archive.read("data"))
        module = data["policy_class"]["__module__"]
    except (KeyError, TypeError, ValueError, OSError, zipfile.BadZipFile):
        return ""
    return module if isinstance(module, str) else ""


def _load_continuous(path: Path, adapter, env, saved: set[str]) -> Agent:
    """A SAC, TD3, PPO or A2C agent with a ``Box`` action space (of the adapter's
    components, when one is given)."""
    import stable_baselines3 as sb3

    module = _policy_module(path)
    if module.startswith(("stable_baselines3.dqn.", "sb3_contrib.common.maskable.")):
        kind = "DQN" if "dqn" in module else "MaskablePPO"
        raise InputError(f"{path}: the agent is a {kind}, which chooses among discrete "
                         f"actions; {adapter.name} takes continuous actions (a Box of "
                         f"{len(next(iter(adapter.parameters.values())))})",
                         hint="train one: tracecheck train --env … --algorithm sac")
    if module.startswith("stable_baselines3.sac."):
        name, cls = "SAC", sb3.SAC
    elif module.startswith("stable_baselines3.td3."):
        name, cls = "TD3", sb3.TD3
    elif "clip_range" in saved:
        name, cls = "PPO-continuous", sb3.PPO
    else:
        name, cls = "A2C-continuous", sb3.A2C
    try:
        model = cls.load(path, device="cpu")
    except Exception as exc:  # noqa: BLE001 - the file's own problem, said
        raise InputError(f"{path} is not a stable-baselines3 {name.split('-')[0]} agent "
                         f"({type(exc).__name__}: {exc})") from None
    space = model.action_space
    shape = getattr(space, "shape", None)
    if getattr(space, "n", None) is not None or shape is None or len(shape) != 1:
        if adapter is not None and adapter.parameters:
            raise InputError(f"{path}: the agent has action space {space}; {adapter.name} "
                             "takes continuous actions (a one-dimensional Box)")
        raise InputError(f"{path}: the agent has action space {space}, neither discrete "
                         "actions nor a one-dimensional Box")
    if adapter is not None:
        if not adapter.parameters:
            raise InputError(f"{path}: the agent ({name.split('-')[0]}) takes continuous "
                             f"actions ({space}); {adapter.name} has {len(adapter.actions)} "
                             f"discrete actions ({', '.join(adapter.actions)})",
                             hint=_PARAMETERS_HINT.format(op=adapter.actions[0]))
        takes = _components(adapter, env)
        if shape != (len(takes),):
            raise InputError(f"{path}: the agent acts with {shape[0]} component(s) ({space}); "
                             f"{adapter.name} takes {len(takes)} ({', '.join(takes)})")
        _check_observations(path, model.observation_space, adapter, env)
    return Agent(str(path), file_sha256(path), name, model)


#: what an adapter of continuous actions declares (an agent acting with vectors met one
#: that declares none)
_PARAMETERS_HINT = ("an environment with continuous actions declares which REAL parameters of "
                    "which operation they bind: parameters = {{\"{op}\": (\"u\",)}} in the "
                    "adapter (docs/continuous.md)")


def _components(adapter, env) -> list[str]:
    """What each component of a continuous agent's action is for ``adapter`` (in ``env``):
    its parameters, or for a hybrid space a score per action and then the parameters
    (:mod:`tracecheck.live.continuous`)."""
    params = [p for op in adapter.actions for p in adapter.parameters.get(op, ())]
    if env is None:
        return params
    from .continuous import space_parts

    hybrid, _ = space_parts(adapter, env.action_space)
    return [f"score of {op}" for op in adapter.actions] + params if hybrid else params


def _saved_settings(path: Path) -> set[str]:
    """The names of the settings a stable-baselines3 file holds (its ``data`` member; none
    when it has no such member, and then no algorithm loads it)."""
    try:
        with zipfile.ZipFile(path) as archive:
            data = json.loads(archive.read("data"))
    except (KeyError, ValueError, OSError, zipfile.BadZipFile):
        return set()
    return set(data) if isinstance(data, dict) else set()


def _algorithms(sb3):
    """The algorithms an agent file may hold: stable-baselines3's, and MaskablePPO when
    sb3-contrib is installed."""
    found = [("DQN", sb3.DQN)]
    try:
        from sb3_contrib import MaskablePPO

        found.append(("MaskablePPO", MaskablePPO))
    except ImportError:
        pass
    return found + [("PPO", sb3.PPO), ("A2C", sb3.A2C)]


def _check_observations(path: Path, space, adapter, env) -> None:
    """The agent's observation space must be the environment's — or, for an image, the
    channel-first one stable-baselines3 trains on (its ``VecTransposeImage``: ``(7, 7, 3)``
    becomes ``(3, 7, 7)``, and its policy transposes each observation back when it acts)."""
    if env is None:
        wanted = adapter.observation_shape
        shape = getattr(space, "shape", None)
        if wanted is not None and shape != tuple(wanted) and shape != _channels_first(
                tuple(wanted)):
            raise InputError(f"{path}: the agent observes shape {space.shape}; {adapter.name} "
                             f"gives observations of shape {tuple(wanted)}")
        return
    theirs = env.observation_space
    if _same_space(space, theirs) or _same_space(space, _transposed_image(theirs)):
        return
    raise InputError(f"{path}: the agent observes {space}, but {adapter.name} gives "
                     f"{theirs}", hint="record with the environment (and the --env-config) "
                                       "the agent was trained in")


def _same_space(space, theirs) -> bool:
    return theirs is not None and type(space) is type(theirs) and getattr(
        space, "shape", None) == getattr(theirs, "shape", None) and getattr(
        space, "n", None) == getattr(theirs, "n", None)


def _channels_first(shape: tuple) -> Optional[tuple]:
    return (shape[2], shape[0], shape[1]) if len(shape) == 3 else None


def _transposed_image(space):
    """The channel-first space stable-baselines3 trains an agent on when ``space`` is a
    channel-last image; None for any other space."""
    from stable_baselines3.common.preprocessing import (is_image_space,
                                                        is_image_space_channels_first)

    try:
        if is_image_space(space) and not is_image_space_channels_first(
                space):
            from stable_baselines3.common.vec_env import VecTransposeImage

            return VecTransposeImage.transpose_space(space)
    except (AssertionError, ValueError, TypeError):
        return None
    return None


def _load_table(path: Path, actions: Optional[tuple[str, ...]], env) -> Agent:
    try:
        table = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise InputError(f"{path} is not a Q-table (.npy of numbers): {exc}") from None
    if table.ndim != 2 or table.dtype.kind not in "fiu":
        raise InputError(f"{path}: a Q-table is a 2-D array of numbers (observations × "
                         f"actions), not {table.dtype} of shape {table.shape}")
    if actions is not None and table.shape[1] != len(actions):
        raise InputError(f"{path}: the Q-table has {table.shape[1]} actions; the environment "
                         f"has {len(actions)} ({', '.join(actions)})")
    if not np.all(np.isfinite(table)):
        raise InputError(f"{path}: the Q-table holds NaN or infinite values")
    n = getattr(getattr(env, "observation_space", None), "n", None)
    if env is not None and n != table.shape[0]:
        raise InputError(f"{path}: the Q-table has {table.shape[0]} rows; the environment "
                         f"has {n if n is not None else 'no discrete'} observations")
    return Agent(str(path), file_sha256(path), "q-learning", table.astype(np.float64))


def agent_outputs(out: Path, example: str, *, force: bool = False,
                  inputs: Sequence[Path] = ()) -> tuple[Path, Path]:
    """The agent file and its model card (``NAME.json`` beside it), checked by the output
    rule (:mod:`tracecheck.outputs`) before any training: neither is one of ``inputs``, and
    existing ones are replaced only with ``force``, each once complete."""
    from ..outputs import check_output

    card = out.with_suffix(".json")
    check_output(out, inputs, force=force, example=example)
    check_output(card, inputs, force=force, what="model card")
    return out, card


def save_model(model, path: Path) -> None:
    """A stable-baselines3 model saved to ``path`` (renamed into place once complete)."""
    from ..outputs import atomic_file

    with atomic_file(path) as stream:
        model.save(stream)


def write_card(card: dict, path: Path) -> None:
    from ..outputs import write_file
    from ..jsontext import json_text

    write_file(path, json_text(card, indent=2) + "\n")


#: the algorithms that take only one kind of action space: continuous (True) or discrete
_ONE_KIND = {"DQN": False, "MaskablePPO": False, "q-learning": False, "SAC": True, "TD3": True}


def card_environment(agent: str | Path) -> tuple[str, str]:
    """The environment an agent was trained in, as its model card (``NAME.json`` beside it)
    says: an installed environment's name, or a Gymnasium id that one installed environment
    has (for a command given no ``--env``).

    Args:
        agent: the agent file.

    Returns:
        (the environment's name, what it was read from, for people).

    Raises:
        InputError: the card is missing, names no environment, or names one that no single
            installed environment is — saying which ``--env`` to give.
    """
    from ..inputs import read_json
    from .adapter import adapters, adapters_for_env_id

    if not Path(agent).is_file():
        raise InputError(f"no such agent file: {agent}")
    card_path = Path(agent).with_suffix(".json")
    installed = sorted(a.name for a in adapters() if a.adapter is not None)
    hint = f"give --env NAME (installed: {', '.join(installed)}) or --env package.module:Class"
    if not card_path.is_file():
        raise InputError(f"no --env given, and the agent {agent} has no model card "
                         f"({card_path.name}) naming its environment", hint=hint)
    card = read_json(card_path, "model card")
    named = card.get("environment") if isinstance(card, dict) else None
    if not isinstance(named, str) or not named:
        raise InputError(f"no --env given, and the model card {card_path} names no "
                         "environment", hint=hint)
    if named in installed:
        return named, f"the model card {card_path}"
    found = [a.adapter for a in adapters_for_env_id(named)]
    algorithm = card.get("algorithm") if isinstance(card, dict) else None
    if len(found) > 1 and algorithm in _ONE_KIND:  # the algorithm says which action space
        found = [a for a in found if bool(a.parameters) == _ONE_KIND[algorithm]]
    if len(found) == 1:
        return found[0].name, f"the model card {card_path} (Gymnasium id {named})"
    if found:
        raise InputError(f"no --env given, and the model card {card_path} names the "
                         f"Gymnasium id {named}, which several installed environments have: "
                         f"{', '.join(a.name for a in found)}",
                         hint="give --env with one of them")
    raise InputError(f"no --env given, and the environment {named!r} of the model card "
                     f"{card_path} is not installed here", hint=hint)


def card_config_note(agent: str | Path, adapter) -> Optional[str]:
    """A note for a run of ``agent`` in ``adapter``'s environment with its default
    configuration where the agent's model card says it was trained with other values of
    the dynamics (``is_slippery``): the agent then meets a world it never learnt. None where
    the card says nothing of it, names another environment, or agrees."""
    from ..inputs import read_json

    card_path = Path(agent).with_suffix(".json")
    try:
        card = read_json(card_path, "model card") if card_path.is_file() else None
    except InputError:
        return None  # a card it cannot read says nothing here; commands that need it say so
    trained = card.get("environment_config") if isinstance(card, dict) else None
    if not isinstance(trained, dict) or card.get("environment") not in (
            adapter.name, adapter.env_id):
        return None
    default = adapter.config(None) or {}
    differ = {k: v for k, v in trained.items() if k in default and default[k] != v}
    if not differ:
        return None
    import json

    said = ", ".join(f"{k} = {v!r}" for k, v in differ.items())
    give = " ".join(f"--env-config {k}={json.dumps(v)}" for k, v in differ.items())
    return (f"note: {Path(agent).name} was trained with {said} (its model card); this run "
            f"takes {adapter.name}'s default, "
            + ", ".join(f"{k} = {default[k]!r}" for k in differ) + f" ({give} gives the card's)")
