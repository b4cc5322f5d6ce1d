"""The environment seam: one adapter per Gymnasium environment.

An adapter is the one place that knows an environment: its Gymnasium id and configuration,
which action index is which B operation, how an observation becomes a B state, what a crash
is, how long an episode may last. Recording, shielding, training and re-simulation use only
this interface; replay, diff and statistics never make an environment (they read the installed
adapters' declarations: the shields and property sets they bring, the runs they claim).

An adapter class is the environment's one descriptor: besides the hooks, it declares the
shields and property sets it brings (``--shield``/``--properties`` names), a one-line
description, its training presets, the scene it is drawn with and whether a run that names no
environment is in its vocabulary. Adapters are found through the entry-point group
``tracecheck.environments`` (:mod:`tracecheck.registry`; the built-in ones are registered there
too) or given on the command line as ``package.module:Class``. A name stored in a file is only
ever looked up among the installed entry points — never imported as a module path — because
importing an adapter runs code.

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
from pathlib import Path
from typing import TYPE_CHECKING, Any, Collection, Mapping, Optional

from ..errors import InputError, TracecheckError
from .adapter_checks import USERS, check_attributes, raised
from .settings import gymnasium_keys, gymnasium_kinds, setting_kinds, typed_setting
from .. import registry
from ..registry import ENTRY_POINT_GROUP

if TYPE_CHECKING:
    from ..episodes.vocabulary import Vocabulary
    from .scene import Scene

__all__ = ["EnvAdapter", "Observer", "adapters", "get_adapter", "installed_adapter",
           "load_adapter", "AdapterInfo",
           "ENTRY_POINT_GROUP", "MakeError", "GymnasiumAdapter",
           "adapters_for_env_id", "claiming_adapter", "run_adapter"]



class Observer:
    """Turns one episode's observations into B states (it may remember earlier steps)."""

    def __init__(self, adapter: "EnvAdapter", env) -> None:
        self.adapter, self.env = adapter, env

    def state(self, obs, info: dict, reward: float, initial: bool) -> dict[str, Any]:
        return self.adapter.state(obs, info, reward, self.env, initial)


class EnvAdapter:
    """What tracecheck knows of an environment: its one descriptor (see the module docstring).

    Subclasses set the class attributes and implement :meth:`make_env` and :meth:`state`;
    everything else has a default. Registered by one entry point of
    ``tracecheck.environments`` (or given as ``--env package.module:Class``), an adapter is
    seen by every command: ``tracecheck envs`` lists it with what it brings.

    Example::

        class Corridor(EnvAdapter):
            name = "corridor"
            description = "a corridor with a pit at one end"
            env_id = "Corridor-v0"
            actions = ("Left", "Right")
            variables = ("pos",)
            shields = {"corridor": Path(__file__).with_name("corridor.mch")}

            def make_env(self, config, render_mode=None):
                return CorridorEnv(**config)

            def state(self, obs, info, reward, env, initial):
                return {"pos": int(obs)}
    """

    #: short name (``--env corridor``)
    name: str = ""
    #: one line for people: what the environment is (``tracecheck envs``)
    description: str = ""
    #: the Gymnasium id
    env_id: str = ""
    #: action index -> B operation name
    actions: tuple[str, ...] = ()
    #: the B variables each state has
    variables: tuple[str, ...] = ()
    #: the B machine the states belong to (run headers name it)
    model_name: str = ""
    #: the set of elements of that machine that ProB's traces list (``setNames``), if any
    set_name: str = ""
    #: a shield that fits (a built-in one's name or a .mch path): ``tracecheck envs`` lists
    #: it, and LTL/STL properties in ``stats`` are read in its machine
    default_shield: Optional[str] = None
    #: taken when the shield allows nothing (None: the first action)
    fallback: Optional[str] = None
    #: continuous actions (a Gymnasium ``Box`` action space): the operation the action is
    #: and the REAL parameter of it that each component of the action vector binds, in
    #: order — ``{"ACCELERATE": ("a",)}`` for ``Box(-1, 1, (1,))``, ``{"DRIVE": ("a",
    #: "steering")}`` for two components (docs/continuous.md). A hybrid space (a discrete
    #: choice of operation, each with its own parameters: ``Tuple((Discrete(n), Tuple((Box,
    #: …))))``) names each action that has parameters. Empty: discrete actions.
    parameters: dict[str, tuple[str, ...]] = {}
    #: continuous actions: the values of the fallback operation's parameters taken when the
    #: shield allows nothing (None: the zero vector, moved into the space's bounds)
    fallback_action: Optional[tuple[float, ...]] = None
    #: seconds of environment time per agent step (step times in the files)
    seconds_per_step: float = 1.0
    #: the longest episode, in agent steps, unless the user sets one
    horizon: int = 100
    #: Python packages the environment needs (``tracecheck envs`` says whether they are here)
    requires: tuple[str, ...] = ("gymnasium",)
    #: named configurations (``--profile``, e.g. reward profiles)
    profiles: dict[str, dict[str, Any]] = {}
    #: the shields this environment brings, by name: ``--shield NAME`` anywhere loads the
    #: ``.mch`` file at that path (absolute, e.g. ``Path(__file__).with_name("corridor.mch")``)
    shields: Mapping[str, str | Path] = {}
    #: the property sets this environment brings, by name (``--properties NAME``): the text
    #: of a property file (TOML), or the :class:`~pathlib.Path` of one
    property_sets: Mapping[str, str | Path] = {}
    #: the environment's own property set, which ``stats`` adds to the generic one (a
    #: property set's name or the path of a property file), if any
    properties: Optional[str] = None
    #: the shape of the observations its agents take, checked when an agent is loaded before
    #: the environment is made (None: checked against the environment once it is made)
    observation_shape: Optional[tuple[int, ...]] = None
    #: B predicates every state of this environment satisfies (declared value ranges, e.g.
    #: ``x : 0..7``); ``prove --env`` assumes them. Only what the environment guarantees:
    #: a range stated too narrowly would make a proof wrong.
    assumptions: tuple[str, ...] = ()
    #: what a search (``falsify --param NAME=LO..HI``) may set at the start of an episode
    #: besides the environment's settings — its initial state: name -> one line saying what
    #: it sets (``{"other_speed": "the other vehicles' initial speed, m/s"}``). The values a
    #: search chooses reach :meth:`reset` as its ``options``.
    reset_parameters: Mapping[str, str] = {}

    def default_config(self) -> dict[str, Any]:
        """The environment configuration used when the user gives none."""
        return {}

    def config(self, overrides: Optional[dict[str, Any]] = None,
               profile: Optional[str] = None, horizon: Optional[int] = None) -> dict[str, Any]:
        """The default configuration, a profile on top, then the user's settings (an
        environment whose configuration holds its episode length also takes ``horizon``)."""
        overrides = self.check_config(overrides)
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

    def config_kinds(self) -> dict[str, Optional[frozenset[str]]]:
        """What each setting takes (:func:`setting_kinds`: ``bool``, ``int``, ``float``,
        ``str``, ``None``, ``list``, ``tuple``, ``dict``; None: anything), by default from the
        type of its value in :meth:`default_config`."""
        return {k: setting_kinds(v) for k, v in self.default_config().items()}

    def check_config(self, overrides: Optional[dict[str, Any]]) -> Optional[dict[str, Any]]:
        """``overrides`` typed as the environment takes them (an integer for a float setting
        becomes a float); a setting the environment does not take (some would ignore it
        silently), or a value that does not fit its setting (``is_slippery='False'``, a
        non-empty string, is true), is refused."""
        if not overrides:
            return overrides
        keys = self.config_keys()
        unknown = sorted(set(overrides or ()) - set(keys)) if keys is not None else []
        if unknown:
            raise InputError(f"unknown setting {unknown[0]!r} for the environment {self.name}; "
                             f"it takes {', '.join(sorted(keys)) or 'none'}",
                             hint="tracecheck bounds episodes itself: --duration N"
                             if unknown[0] == "max_episode_steps"
                             else "--env-config key=value, one of those keys")
        kinds = self.config_kinds()
        return {k: typed_setting(self.name, k, v, kinds.get(k)) for k, v in overrides.items()}

    def make_env(self, config: dict[str, Any], render_mode: Optional[str] = None):
        """Make the environment.

        Args:
            config: its configuration (:meth:`config`: the defaults, a profile, the
                user's ``--env-config``).
            render_mode: Gymnasium's ``render_mode``, if one is asked for.

        Returns:
            A ``gymnasium.Env``.
        """
        raise NotImplementedError

    def reset(self, env, seed: Optional[int], options: Optional[dict[str, Any]] = None):
        """Start an episode: reset the environment, and set what ``options`` says.

        Args:
            env: the environment :meth:`make_env` made.
            seed: the episode's seed.
            options: values of :attr:`reset_parameters` a search chose (None: none).

        Returns:
            ``(observation, info)`` as ``env.reset`` returns them. By default
            ``env.reset(seed=seed, options=options)``: an environment whose ``reset`` reads
            these options needs nothing more; an adapter that sets the state itself resets,
            changes the state, and returns the observation of the changed state.
        """
        return env.reset(seed=seed, options=options)

    def observer(self, env) -> Observer:
        """A fresh observer for one environment (its memory spans one episode)."""
        return Observer(self, env)

    def state(self, obs, info: dict, reward: float, env, initial: bool) -> dict[str, Any]:
        """The B state of an observation.

        Args:
            obs: the observation ``reset`` or ``step`` returned.
            info: the info dict with it.
            reward: the step's reward (0 after ``reset``).
            env: the environment (for what the observation does not hold, e.g. a map).
            initial: whether this is the observation of ``reset``.

        Returns:
            ``{variable: value}`` for each of :attr:`variables`: Python or numpy values
            the shield's types make B values (:mod:`tracecheck.b.conversion`; a ``str``
            naming an element, a ``dict`` for a function: docs/environments.md, "States").
        """
        raise NotImplementedError

    def crashed(self, obs, reward: float, terminated: bool, info: dict) -> bool:
        """Whether this step ended in the failure the shield is meant to prevent.

        Args:
            obs: the observation after the step.
            reward: the step's reward.
            terminated: Gymnasium's ``terminated``.
            info: the step's info dict.

        Returns:
            True for a crash; by default ``info["crashed"]``.
        """
        return bool(info.get("crashed", False))

    def fallback_index(self) -> int:
        return self.actions.index(self.fallback) if self.fallback else 0

    def scene(self, step, shield: Optional[str] = None) -> Optional["Scene"]:
        """What a step looks like, for the viewer, the report and Foxglove (optional).

        Args:
            step: a ``StepRecord``: its B state ``step.state`` and ``step.crashed``.
            shield: the name of the shield the run is drawn with (a scene may show what
                that shield's guards test); an adapter whose ``scene`` takes only ``step``
                is called without it.

        Returns:
            A :class:`tracecheck.live.scene.Scene` of boxes, circles, lines and text; None:
            no picture (the viewer then shows the time series and the state table). See
            docs/environments.md, "Drawing your environment".
        """
        return None

    #: the names of the numbers :meth:`plots` gives (Foxglove's ``/plot/NAME`` channels)
    plotted: tuple[str, ...] = ()

    def plots(self, state: dict[str, Any]) -> dict[str, float]:
        """Numbers of a state worth a line of their own in Foxglove's Plot panel
        (``/plot/NAME``), e.g. a speed or a distance; none by default.

        Args:
            state: a B state of this environment.

        Returns:
            ``{name: value}``; a name the state has no value for is left out.
        """
        return {}

    def training_settings(self, algorithm: str, steps: int) -> dict[str, Any]:
        """The environment's own training settings for ``train``, on top of the algorithm's
        defaults (e.g. a discount factor, or a paper's settings).

        Args:
            algorithm: the ``--algorithm`` (``dqn``, ``ppo``, ``a2c``, ``maskable-ppo``,
                ``sac``, ``td3``).
            steps: the environment steps the training runs.

        Returns:
            Keyword arguments of the algorithm's class; none by default.
        """
        return {}

    def vocabulary(self) -> "Vocabulary":
        """The variables and actions of this environment's states, as traces are read in
        (``import simb --env``) and written."""
        from ..episodes.vocabulary import Vocabulary

        return Vocabulary(tuple(self.variables), tuple(self.actions),
                          self.model_name or self.name, self.set_name)

    def claims(self, variables: Collection[str]) -> bool:
        """Whether a run that names no environment (an imported trace, a file from before
        environments were recorded) has this environment's states: ``variables`` are the
        run's state variables. False by default: only an environment whose vocabulary
        others share (a paper's traces) claims such runs.
        """
        return False

    def describe(self, state: dict[str, Any]) -> Optional[str]:
        """A B state in one line for people (optional): how ``prove`` and ``diff
        --symbolic`` show a counterexample in this environment's states. None: as its
        variables' values."""
        return None


@dataclass(frozen=True)
class AdapterInfo:
    name: str
    target: str
    adapter: Optional[EnvAdapter]
    problem: Optional[str]


def adapters() -> list[AdapterInfo]:
    """Every installed adapter, loaded where it can be (else the reason it cannot)."""
    out = []
    for entry in registry.registered():
        adapter, problem = None, entry.problem
        if entry.cls is not None:
            try:
                adapter = _instance(entry.cls, entry.target)
            except USERS as exc:  # noqa: BLE001 - a broken plug-in must not stop the list
                problem = f"{type(exc).__name__}: {exc}"
        out.append(AdapterInfo(entry.name, entry.target, adapter, problem))
    return out


def run_adapter(environment: Optional[str],
                variables: Collection[str] = ()) -> Optional[EnvAdapter]:
    """The installed adapter of a run: the one its header names, else the one that claims
    its state ``variables`` (a run that names no environment); None when neither is
    installed here.

    Args:
        environment: the environment the run's header names (None: it names none).
        variables: the run's state variables (its header's).
    """
    if environment:
        return installed_adapter(environment, required=False)
    return claiming_adapter(variables) if variables else None


def claiming_adapter(variables: Collection[str]) -> Optional[EnvAdapter]:
    """The installed adapter that claims a run naming no environment, by its state
    ``variables`` (:meth:`EnvAdapter.claims`); None when none does."""
    claiming = []
    for info in adapters():
        if info.adapter is None:
            continue
        try:
            if info.adapter.claims(tuple(variables)):
                claiming.append(info.adapter)
        except TracecheckError:  # a plug-in's failing claims(): it claims nothing
            continue
    if len(claiming) > 1:
        raise InputError(f"the run names no environment, and {', '.join(a.name for a in claiming)} "
                         "all claim its states", hint="give the environment with --env")
    return claiming[0] if claiming else None


def adapters_for_env_id(env_id: Optional[str],
                        found: Optional[list[AdapterInfo]] = None) -> list[AdapterInfo]:
    """The installed adapters (those that load) whose ``env_id`` is ``env_id``, among
    ``found`` (:func:`adapters`, when listed already)."""
    return [a for a in (adapters() if found is None else found)
            if a.adapter is not None and a.adapter.env_id == env_id]


def get_adapter(name: Optional[str]) -> EnvAdapter:
    """The installed adapter registered under ``name``."""
    if not name:
        raise InputError("no environment named: give --env NAME (installed: "
                         f"{', '.join(sorted(registry.entry_points()))}) or --env "
                         "package.module:Class", hint="tracecheck envs lists them")
    ep = registry.entry_points().get(name)
    if ep is None:
        raise InputError(f"unknown environment {name!r}; the installed ones are "
                         f"{', '.join(sorted(registry.entry_points()))}",
                         hint=_name_hint(name))
    try:
        loaded = ep.load()
    except USERS as exc:  # noqa: BLE001 - the plug-in's own code
        raise raised(name, exc, "when it was imported") from exc
    return _instance(loaded, name)


def installed_adapter(environment, *, required: bool = True) -> Optional[EnvAdapter]:
    """The adapter of an environment name (installed adapters only: a name in a file is
    never imported), or the adapter itself; None when ``required`` is False and it is not
    installed."""
    if isinstance(environment, EnvAdapter):
        return environment
    try:
        return get_adapter(environment)
    except InputError:
        if required:
            raise
        return None


_SPEC = re.compile(r"[A-Za-z_]\w*(\.[A-Za-z_]\w*)*:[A-Za-z_]\w*(\.[A-Za-z_]\w*)*")


def load_adapter(spec: Optional[str]) -> EnvAdapter:
    """An adapter from the command line: an installed name, or ``package.module:Class``."""
    if spec is None or ":" not in spec:
        return get_adapter(spec)
    if not _SPEC.fullmatch(spec):
        path, _, attr = spec.partition(":")
        module, folder = _module_of_file(path)
        raise InputError(f"--env {spec!r} is not an adapter: give an installed one's name "
                         f"({', '.join(sorted(registry.entry_points()))}) or package.module:Class, "
                         "e.g. my_envs.corridor:Corridor",
                         hint=f"for the file {path}: --env {module}:{attr or 'YourAdapter'} "
                              f"with PYTHONPATH={folder or '.'}"
                         if "/" in path or path.endswith(".py") else None)
    module_name, _, attr = spec.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise InputError(f"cannot import the adapter module {module_name!r}: {exc}",
                         hint=_import_hint(module_name, attr, exc)) from None
    except USERS as exc:  # noqa: BLE001 - the module's own code
        raise raised(spec, exc, "when its module was imported") from exc
    cls = module
    for part in attr.split("."):
        cls = getattr(cls, part, None)
    found = sorted(n for n, v in vars(module).items() if isinstance(v, type) and
                   issubclass(v, EnvAdapter) and v.__module__ == module.__name__)
    hint = f"its adapters: {', '.join(found)}" if found else \
        "it defines no EnvAdapter subclass (see docs/environments.md)"
    if cls is None:
        raise InputError(f"the module {module_name} has no {attr!r}", hint=hint)
    if isinstance(cls, type) and not issubclass(cls, EnvAdapter):
        what = "a Gymnasium environment" if _is_env(cls) else "a class"
        raise InputError(f"{spec} is {what}, not a tracecheck EnvAdapter: --env takes the "
                         "adapter that makes the environment and reads its states", hint=hint)
    return _instance(cls, spec)


def _is_env(cls: type) -> bool:
    import gymnasium as gym

    return issubclass(cls, gym.Env)


def _module_of_file(path: str) -> tuple[str, str]:
    """(the module name, the folder to put on PYTHONPATH) of a Python file given as
    ``--env``: its folders with an ``__init__.py`` are its packages
    (``thermo/adapter.py`` in the package thermo: ``thermo.adapter``, from ``.``)."""
    folder, _, file = path.replace("\\", "/").rpartition("/")
    parts = [file[:-3] if file.endswith(".py") else file]
    while folder and Path(folder, "__init__.py").is_file():
        folder, _, package = folder.rpartition("/")
        parts.insert(0, package)
    return ".".join(parts), folder or "."


def _name_hint(name: str) -> str:
    """What an unknown ``--env`` name would be as an adapter of the user's own module."""
    stem = name[:-3] if name.endswith(".py") else None
    if "/" in name or "\\" in name or (stem is not None and "." not in stem):
        module = (stem or name).replace("\\", "/").rstrip("/").split("/")[-1]
        return (f"--env takes a module's name, not a file: --env {module}:YourAdapter, with "
                "the module's folder on PYTHONPATH")
    module, dot, attr = name.rpartition(".")
    dotted = bool(dot) and _SPEC.fullmatch(f"{module}:{attr}") is not None
    if dotted and attr[:1].isupper():
        return f"an adapter in a module of yours is --env {module}:{attr} (a colon before " \
               "the class)"
    if dotted:  # a module's name: its class after a colon
        return f"an adapter in the module {name} is --env {name}:YourAdapter (a colon, then " \
               "the adapter's class)"
    return "give your own adapter as --env package.module:Class"


def _import_hint(module_name: str, attr: str, exc: ImportError) -> Optional[str]:
    """What to do where ``--env module_name:attr`` did not import."""
    top = module_name.split(".")[0]
    if module_name.endswith(".py"):
        return f"name the module without .py: --env {module_name[:-3]}:{attr}"
    if isinstance(exc, ModuleNotFoundError) and exc.name == top:
        return (f"put the folder that holds {top}.py (or the package {top}/) on PYTHONPATH, "
                f"e.g. PYTHONPATH=. when it is the folder you are in: Python looks there and "
                "in the installed packages, not in the current folder")
    return None


#: the hooks whose exceptions are reported as the adapter's (with its name and the hook)
_HOOKS = ("make_env", "reset", "state", "crashed", "default_config", "config", "config_keys",
          "fallback_index", "scene", "describe", "claims", "plots", "training_settings")


def _guarded(method, where: str, hook: str):
    @functools.wraps(method)
    def call(*args, **kwargs):
        try:
            return method(*args, **kwargs)
        except TracecheckError:
            raise
        except USERS as exc:  # noqa: BLE001 - the user's code: say whose it is
            error = raised(where, exc, f"in {hook}()")
            if hook == "make_env":  # a setting it does not take: which it has
                owner = getattr(method, "__self__", None)  # (a staticmethod has none)
                error.hint = (_unknown_setting(owner, exc) if owner is not None else None) \
                    or error.hint
            raise error from exc
    return call


class MakeError(InputError):
    """The environment refused the settings it was made with (``reason``: its exception)."""

    reason = ""


def _making(adapter: EnvAdapter):
    """``adapter.make_env``, an exception the environment raises on its settings (a map
    name gymnasium does not have: KeyError) reported as exit 2 naming the environment and
    the settings that differ from its defaults; ``--debug`` shows its traceback."""
    make = adapter.make_env

    @functools.wraps(make)
    def make_env(config, *args, **kwargs):
        try:
            return make(config, *args, **kwargs)
        except TracecheckError:
            raise
        except USERS as exc:  # noqa: BLE001 - the environment's own check of its settings
            reason = f"{type(exc).__name__}: {exc}"
            error = MakeError(f"cannot make the environment {adapter.name} with "
                              f"{_settings(adapter, config)}: {reason}",
                              hint=_unknown_setting(adapter, exc) or
                              "tracecheck --debug … shows its traceback")
            error.reason = reason
            raise error from exc
    return make_env


def _unknown_setting(adapter: EnvAdapter, exc: BaseException) -> Optional[str]:
    """Where the environment refused a keyword it does not take (``--env-config humidity=1``
    of one without it): the settings its adapter's defaults name."""
    import re

    found = re.search(r"unexpected keyword argument '([^']+)'", str(exc)) \
        if isinstance(exc, TypeError) else None
    if found is None:
        return None
    try:
        known = sorted(adapter.default_config())
    except Exception:  # noqa: BLE001 - said where it is used
        known = []
    return (f"{found.group(1)} is no setting the environment takes"
            + (f"; its default settings are {', '.join(known)}" if known else "")
            + " (the adapter's config_keys() would refuse it before making anything)")


def _settings(adapter: EnvAdapter, config) -> str:
    """The settings of ``config`` that differ from the adapter's defaults, as key=value."""
    try:
        default = adapter.default_config()
    except Exception:  # noqa: BLE001 - said where it is used
        default = {}
    changed = {k: v for k, v in dict(config or {}).items() if k not in default or default[k] != v}
    return ", ".join(f"{k}={v!r}" for k, v in changed.items()) or "its default settings"


def _instance(cls, where: str) -> EnvAdapter:
    try:
        adapter = cls() if isinstance(cls, type) else cls
    except USERS as exc:  # noqa: BLE001 - the user's constructor
        raise raised(where, exc, "in its constructor") from exc
    if not isinstance(adapter, EnvAdapter):
        raise InputError(f"{where} is not a tracecheck EnvAdapter")
    check_attributes(adapter, where)
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
    if not getattr(adapter, "_tracecheck_making", False):
        adapter.make_env = _making(adapter)
        adapter._tracecheck_making = True
    return adapter


class GymnasiumAdapter(EnvAdapter):
    """An adapter for an environment registered with Gymnasium under ``env_id``: made with
    ``gymnasium.make(env_id, **config).unwrapped`` (no time limit of Gymnasium's own: the
    adapter's ``horizon`` bounds episodes), its settings those the registered class takes —
    not ``max_episode_steps``, which the unwrapped environment would ignore (``--duration``
    sets how long an episode may last)."""

    def config_keys(self):
        keys = gymnasium_keys(self.env_id)
        return None if keys is None else keys - {"max_episode_steps"}

    def config_kinds(self):
        kinds = gymnasium_kinds(self.env_id)
        kinds.pop("max_episode_steps", None)
        return kinds

    def make_env(self, config: dict[str, Any], render_mode: Optional[str] = None):
        import gymnasium as gym

        return gym.make(self.env_id, render_mode=render_mode, **config).unwrapped
