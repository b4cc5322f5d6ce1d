"""The environment seam: one adapter per Gymnasium environment.

An adapter is the one place that knows an environment: its Gymnasium id and configuration,
which action index is which B operation, how an observation becomes a B state, what a crash
is, how long an episode may last. Recording, shielding, training and re-simulation use only
this interface; replay, diff and statistics never import an environment at all.

Adapters are found through the entry-point group ``tracecheck.environments`` (the built-in
ones are registered there too) or given on the command line as ``package.module:Class``. A
name stored in a file is only ever looked up among the installed entry points — never
imported as a module path — because importing an adapter runs code.

An adapter is checked when it is loaded (a name, actions that are distinct strings), and an
exception from a user's adapter — its module, constructor, ``make_env``, ``state`` and the
other hooks — comes out as an :class:`~tracecheck.errors.InputError` naming the adapter and the hook
(``the adapter acc_cruise:ACC raised ValueError in state(): …``), the original exception as
its ``__cause__`` (``tracecheck --debug`` prints its traceback).

A minimal adapter::

    class Corridor(EnvAdapter):
        name = "corridor"
        env_id = "Corridor-v0"
        actions = ("Left", "Right")
        variables = ("pos",)

        def make_env(self, config, render_mode=None):
            return CorridorEnv(**config)

        def state(self, obs, info, reward, env, initial):
            return {"pos": int(obs)}
"""

from __future__ import annotations

import functools
import importlib
import re
from dataclasses import dataclass
from importlib import metadata
from typing import TYPE_CHECKING, Any, Collection, Optional

from ..errors import InputError, TracecheckError

if TYPE_CHECKING:
    from ..render.scene import Scene

__all__ = ["EnvAdapter", "Observer", "adapters", "get_adapter", "load_adapter", "AdapterInfo",
           "ENTRY_POINT_GROUP", "parse_config"]

ENTRY_POINT_GROUP = "tracecheck.environments"


class Observer:
    """Turns one episode's observations into B states (it may remember earlier steps)."""

    def __init__(self, adapter: "EnvAdapter", env) -> None:
        self.adapter, self.env = adapter, env

    def state(self, obs, info: dict, reward: float, initial: bool) -> dict[str, Any]:
        return self.adapter.state(obs, info, reward, self.env, initial)


class EnvAdapter:
    """What tracecheck needs to know of an environment (see the module docstring).

    Subclasses set the class attributes and implement :meth:`make_env` and :meth:`state`;
    everything else has a default.
    """

    #: short name (``--env frozenlake``)
    name: str = ""
    #: the Gymnasium id
    env_id: str = ""
    #: action index -> B operation name
    actions: tuple[str, ...] = ()
    #: the B variables each state has
    variables: tuple[str, ...] = ()
    #: the B machine the states belong to (run headers name it)
    model_name: str = ""
    #: a shield that fits (a built-in one's name or a .mch path): ``tracecheck envs`` lists
    #: it, and LTL/STL properties in ``stats`` are read in its machine
    default_shield: Optional[str] = None
    #: taken when the shield allows nothing (None: the first action)
    fallback: Optional[str] = None
    #: seconds of environment time per agent step (step times in the files)
    seconds_per_step: float = 1.0
    #: the longest episode, in agent steps, unless the user sets one
    horizon: int = 100
    #: Python packages the environment needs (``tracecheck envs`` says whether they are here)
    requires: tuple[str, ...] = ("gymnasium",)
    #: named configurations (the highway's reward profiles)
    profiles: dict[str, dict[str, Any]] = {}
    #: the environment's own property set, which ``stats`` adds to the generic one (a
    #: built-in set's name or the path of a property file), if any
    properties: Optional[str] = None
    #: B predicates every state of this environment satisfies (declared value ranges, e.g.
    #: ``x : 0..7``); ``prove --env`` assumes them. Only what the environment guarantees:
    #: a range stated too narrowly would make a proof wrong.
    assumptions: tuple[str, ...] = ()

    def default_config(self) -> dict[str, Any]:
        """The environment configuration used when the user gives none."""
        return {}

    def config(self, overrides: Optional[dict[str, Any]] = None,
               profile: Optional[str] = None, horizon: Optional[int] = None) -> dict[str, Any]:
        """The default configuration, a profile on top, then the user's settings (an
        environment whose configuration holds its episode length also takes ``horizon``)."""
        self.check_config(overrides)
        config = dict(self.default_config())
        if profile is not None:
            if profile not in self.profiles:
                raise InputError(f"unknown profile {profile!r} for {self.name}; the profiles "
                                 f"are {', '.join(self.profiles) or 'none'}")
            config.update(self.profiles[profile])
        config.update(overrides or {})
        return config

    def config_keys(self) -> Optional[Collection[str]]:
        """The settings ``make_env`` takes (``--env-config`` keys); None: not known, so not
        checked (the environment itself may then refuse one)."""
        return None

    def check_config(self, overrides: Optional[dict[str, Any]]) -> None:
        """Refuse a setting the environment does not take (some would ignore it silently)."""
        if not overrides:
            return
        keys = self.config_keys()
        unknown = sorted(set(overrides or ()) - set(keys)) if keys is not None else []
        if unknown:
            raise InputError(f"unknown setting {unknown[0]!r} for the environment {self.name}; "
                             f"it takes {', '.join(sorted(keys)) or 'none'}",
                             hint="--env-config key=value, one of those keys")

    def make_env(self, config: dict[str, Any], render_mode: Optional[str] = None):
        raise NotImplementedError

    def observer(self, env) -> Observer:
        """A fresh observer for one environment (its memory spans one episode)."""
        return Observer(self, env)

    def state(self, obs, info: dict, reward: float, env, initial: bool) -> dict[str, Any]:
        """The B state of an observation."""
        raise NotImplementedError

    def crashed(self, obs, reward: float, terminated: bool, info: dict) -> bool:
        """Whether this step ended in the failure the shield is meant to prevent."""
        return bool(info.get("crashed", False))

    def fallback_index(self) -> int:
        return self.actions.index(self.fallback) if self.fallback else 0

    def scene(self, step) -> Optional["Scene"]:
        """What a step looks like, for the viewer and Foxglove (optional): a
        :class:`tracecheck.render.scene.Scene` of boxes, circles, lines and text, drawn from
        ``step.state`` (its B state) and ``step.crashed``; None: no picture (the viewer then
        shows the time series and the state table). See docs/environments.md, "Drawing your
        environment"."""
        return None


@dataclass(frozen=True)
class AdapterInfo:
    name: str
    target: str
    adapter: Optional[EnvAdapter]
    problem: Optional[str]


@functools.lru_cache(maxsize=1)
def _entry_points() -> dict[str, metadata.EntryPoint]:
    """The installed adapters (scanning the installed distributions once per process)."""
    found = {ep.name: ep for ep in metadata.entry_points(group=ENTRY_POINT_GROUP)}
    for name, target in _BUILTIN.items():  # also when running from a source tree
        found.setdefault(name, metadata.EntryPoint(name, target, ENTRY_POINT_GROUP))
    return found


_BUILTIN = {
    "highway": "tracecheck.live.envs.highway:HighwayAdapter",
    "frozenlake": "tracecheck.live.envs.frozenlake:FrozenLakeAdapter",
    "cliffwalking": "tracecheck.live.envs.cliffwalking:CliffWalkingAdapter",
    "lunarlander": "tracecheck.live.envs.lunarlander:LunarLanderAdapter",
}


def adapters() -> list[AdapterInfo]:
    """Every installed adapter, loaded where it can be (else the reason it cannot)."""
    out = []
    for name, ep in sorted(_entry_points().items()):
        try:
            adapter, problem = _instance(ep.load(), ep.value), None
        except Exception as exc:  # noqa: BLE001 - a broken plug-in must not stop the list
            adapter, problem = None, f"{type(exc).__name__}: {exc}"
        out.append(AdapterInfo(name, ep.value, adapter, problem))
    return out


def get_adapter(name: Optional[str]) -> EnvAdapter:
    """The installed adapter registered under ``name`` (None: the highway, the default for
    files recorded before adapters existed)."""
    name = name or "highway"
    ep = _entry_points().get(name)
    if ep is None:
        raise InputError(f"unknown environment {name!r}; the installed ones are "
                         f"{', '.join(sorted(_entry_points()))}",
                         hint="give your own adapter as --env package.module:Class")
    try:
        loaded = ep.load()
    except Exception as exc:  # noqa: BLE001 - the plug-in's own code
        raise _raised(name, exc, "when it was imported") from exc
    return _instance(loaded, name)


_SPEC = re.compile(r"[A-Za-z_]\w*(\.[A-Za-z_]\w*)*:[A-Za-z_]\w*(\.[A-Za-z_]\w*)*")


def load_adapter(spec: Optional[str]) -> EnvAdapter:
    """An adapter from the command line: an installed name, or ``package.module:Class``."""
    if spec is None or ":" not in spec:
        return get_adapter(spec)
    if not _SPEC.fullmatch(spec):
        raise InputError(f"--env {spec!r} is not an adapter: give an installed one's name "
                         f"({', '.join(sorted(_entry_points()))}) or package.module:Class, "
                         "e.g. my_envs.corridor:Corridor")
    module_name, _, attr = spec.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise InputError(f"cannot import the adapter module {module_name!r}: {exc}") from None
    except Exception as exc:  # noqa: BLE001 - the module's own code
        raise _raised(spec, exc, "when its module was imported") from exc
    cls = module
    for part in attr.split("."):
        cls = getattr(cls, part, None)
    if cls is None:
        raise InputError(f"the module {module_name} has no {attr!r}")
    return _instance(cls, spec)


#: the hooks whose exceptions are reported as the adapter's (with its name and the hook)
_HOOKS = ("make_env", "state", "crashed", "default_config", "config", "config_keys",
          "fallback_index", "scene")


def _raised(where: str, exc: BaseException, hook: str) -> InputError:
    return InputError(f"the adapter {where} raised {type(exc).__name__} {hook}: {exc}",
                      hint="tracecheck --debug … shows its traceback")


def _guarded(method, where: str, hook: str):
    @functools.wraps(method)
    def call(*args, **kwargs):
        try:
            return method(*args, **kwargs)
        except TracecheckError:
            raise
        except Exception as exc:  # noqa: BLE001 - the user's code: say whose it is
            raise _raised(where, exc, f"in {hook}()") from exc
    return call


def _instance(cls, where: str) -> EnvAdapter:
    try:
        adapter = cls() if isinstance(cls, type) else cls
    except Exception as exc:  # noqa: BLE001 - the user's constructor
        raise _raised(where, exc, "in its constructor") from exc
    if not isinstance(adapter, EnvAdapter):
        raise InputError(f"{where} is not a tracecheck EnvAdapter")
    if not adapter.name or not adapter.actions:
        raise InputError(f"the adapter {where} needs a name and actions")
    actions = tuple(adapter.actions) if isinstance(adapter.actions, (tuple, list)) else None
    if actions is None or not all(isinstance(a, str) and a for a in actions):
        raise InputError(f"the adapter {where} has actions {adapter.actions!r}; give a tuple "
                         "of operation names, one per action index")
    twice = next((a for i, a in enumerate(actions) if a in actions[:i]), None)
    if twice is not None:
        raise InputError(f"the adapter {where} names the action {twice!r} twice in its "
                         f"actions {actions!r}: each action index needs its own name (the B "
                         "operation it stands for)")
    own = type(adapter).__module__.split(".")[0] == "tracecheck"  # built-in: not guarded
    if not own and not getattr(adapter, "_tracecheck_guarded", False):
        for hook in _HOOKS:
            setattr(adapter, hook, _guarded(getattr(adapter, hook), where, hook))
        observer = adapter.observer

        def guarded_observer(env):
            made = _guarded(observer, where, "observer")(env)
            made.state = _guarded(made.state, where, "state")
            return made

        adapter.observer = guarded_observer
        adapter._tracecheck_guarded = True
    return adapter


def gymnasium_keys(env_id: str) -> Optional[frozenset[str]]:
    """The keyword arguments ``gymnasium.make(env_id, **config)`` takes: those of the
    registered environment class and of ``make`` itself (None where they cannot be known)."""
    import inspect

    import gymnasium as gym
    from gymnasium.envs.registration import load_env_creator

    try:
        entry = gym.spec(env_id).entry_point
        params = inspect.signature(load_env_creator(entry) if isinstance(entry, str)
                                   else entry).parameters
    except Exception:  # noqa: BLE001 - a package missing: make_env will say so
        return None
    if any(p.kind == p.VAR_KEYWORD for p in params.values()):
        return None
    own = {"max_episode_steps", "disable_env_checker"}
    return frozenset(params) - {"render_mode"} | own


def parse_config(items: list[str]) -> dict[str, Any]:
    """``key=value`` settings: values read as JSON where they parse (true, 3, 0.5, "s"),
    else as strings."""
    import orjson

    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise InputError(f"--env-config takes key=value, not {item!r}")
        try:
            out[key] = orjson.loads(value)  # no NaN, nesting bounded
        except orjson.JSONDecodeError:
            out[key] = value
    return out
