"""Shielded vector environments: one batch per step, the same decisions as one by one."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from tracecheck.b.machine import load_machine_text
from tracecheck.b.values import Elem, FuncValue
from tracecheck.checking.shield import load_shield
from tracecheck.errors import InputError
from tracecheck.live.adapter import get_adapter
from tracecheck.live.decisions import Decisions
from tracecheck.live.vector import ShieldedVectorEnv
from tracecheck.live.wrapper import ShieldWrapper

from tests.live.toy import SHIELD, Corridor

N = 6


def _frozenlake():
    adapter = get_adapter("frozenlake")
    shield = load_shield("frozenlake")
    return lambda: ShieldWrapper(adapter.make_env(adapter.config(None)), shield,
                                 adapter=adapter)


def _corridor(text: str = SHIELD, slip: bool = True):
    import tempfile
    from pathlib import Path

    path = Path(tempfile.mkdtemp()) / "corridor.mch"
    path.write_text(text)
    shield = load_shield(path)
    return lambda: ShieldWrapper(Corridor().make_env({"slip": slip}), shield,
                                 adapter=Corridor())


@pytest.fixture
def batches(monkeypatch):
    """How many states each batch evaluation took (the batch path taken whenever it can)."""
    sizes: list[int] = []
    batched = Decisions._batched
    monkeypatch.setattr(Decisions, "_prefer_batch", lambda self: True)

    def counted(self, states):
        out = batched(self, states)
        if out is not None:
            sizes.append(len(states))
        return out

    monkeypatch.setattr(Decisions, "_batched", counted)
    return sizes


def _fields(shield: dict) -> dict:
    return {k: v for k, v in shield.items() if k != "decision_us"}


class Drift(gym.Env):
    """A walker on the real line: Left and Right move it by a random step."""

    def __init__(self):
        self.observation_space = gym.spaces.Box(-10.0, 10.0, (1,))
        self.action_space = gym.spaces.Discrete(2)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.x = float(self.np_random.uniform(-4.0, 4.0))
        return np.array([self.x], dtype=np.float32), {}

    def step(self, action):
        self.x += (1.0 if int(action) else -1.0) * float(self.np_random.uniform(0.0, 1.0))
        return np.array([self.x], dtype=np.float32), 0.0, abs(self.x) > 5.0, False, {}


class DriftAdapter(Corridor):
    name, variables, model_name = "drift", ("x",), "Drift"

    def make_env(self, config, render_mode=None):
        return Drift()

    def state(self, obs, info, reward, env, initial):
        return {"x": obs[0]}  # a float32: converted exactly

    def crashed(self, obs, reward, terminated, info):
        return bool(terminated)


DRIFT = """
MACHINE Drift
VARIABLES x
INVARIANT x : REAL
INITIALISATION x := 0.0
OPERATIONS
  Left = SELECT x - 1.0 > -5.0 & x * x < 20.0 THEN skip END;
  Right = SELECT 1.0 / (5.0 - x) > 0.2 THEN skip END
END
"""


def _drift():
    import tempfile
    from pathlib import Path

    path = Path(tempfile.mkdtemp()) / "drift.mch"
    path.write_text(DRIFT)
    shield = load_shield(path)
    return lambda: ShieldWrapper(Drift(), shield, adapter=DriftAdapter())


@pytest.mark.parametrize("make, n, batched", [(_frozenlake, N, False), (_corridor, N, False),
                                              (_drift, 40, True)],
                         ids=["frozenlake", "corridor", "drift"])
def test_gymnasium_vector_env_decides_as_one_by_one(make, n, batched, batches):
    N = n  # noqa: N806
    factory = make()
    envs = ShieldedVectorEnv(gym.vector.SyncVectorEnv([factory] * N))
    singles = [factory() for _ in range(N)]
    obs, infos = envs.reset(seed=list(range(N)))
    for i, w in enumerate(singles):
        o, info = w.reset(seed=i)
        assert o == obs[i]
        assert infos["shield"]["allowed"][i] == info["shield"]["allowed"]
    rng = np.random.default_rng(1)
    ended = np.zeros(N, dtype=bool)
    for _ in range(60):
        masks = envs.action_masks()
        assert masks.shape == (N, len(singles[0].actions))
        for i, w in enumerate(singles):
            assert masks[i].tolist() == w.action_masks().tolist()
        actions = rng.integers(len(singles[0].actions), size=N)  # blocked ones too
        obs, rewards, terminated, truncated, infos = envs.step(actions)
        for i, w in enumerate(singles):
            if ended[i]:  # Gymnasium's next-step autoreset
                o, info = w.reset()
            else:
                o, r, t, tr, info = w.step(int(actions[i]))
                assert (r, t, tr) == (rewards[i], terminated[i], truncated[i])
            assert o == obs[i]
            got = {k: infos["shield"][k][i] for k in info["shield"]
                   if infos["shield"].get("_" + k, np.zeros(N, bool))[i]}
            assert _fields(got) == _fields(info["shield"])
        ended = terminated | truncated
    # the walker's states decided together; the lake's map is no column and the corridor's
    # six states are soon all remembered: one by one, each distinct state once
    assert bool(batches) == batched and (not batched or max(batches) >= 32)


def test_same_step_autoreset_keeps_the_steps_decision_under_final_info():
    factory = _corridor()
    envs = ShieldedVectorEnv(gym.vector.SyncVectorEnv(
        [factory] * 2, autoreset_mode=gym.vector.AutoresetMode.SAME_STEP))
    envs.reset(seed=[0, 1])
    for _ in range(20):
        *_, terminated, truncated, infos = envs.step(np.array([1, 1]))  # Right: to the goal
        if terminated.any():
            break
    i = int(np.flatnonzero(terminated)[0])
    assert infos["final_info"]["shield"]["allowed"][i] == ["Left"]  # in cell 5
    assert infos["shield"]["allowed"][i] == ["Left", "Right"]  # the reset's state


def test_sb3_vec_env_decides_as_one_by_one(batches):
    from stable_baselines3.common.vec_env import DummyVecEnv

    from tracecheck.live.vector_sb3 import ShieldedVecEnv

    factory, n = _drift(), 40
    venv = ShieldedVecEnv(DummyVecEnv([factory] * n))
    venv.seed(3)
    singles = [factory() for _ in range(n)]
    obs = venv.reset()
    for i, w in enumerate(singles):
        o, info = w.reset(seed=3 + i)
        assert o == obs[i]
        assert _fields(venv.reset_infos[i]["shield"]) == _fields(info["shield"])
    rng = np.random.default_rng(2)
    for _ in range(40):
        masks = venv.action_masks()
        actions = rng.integers(2, size=n)
        obs, rewards, dones, infos = venv.step(actions)
        for i, w in enumerate(singles):
            assert masks[i].tolist() == w.action_masks().tolist()
            o, r, t, tr, info = w.step(int(actions[i]))
            assert _fields(infos[i]["shield"]) == _fields(info["shield"])  # the step's
            if t or tr:  # SB3 resets at once; the reset's decision in reset_infos
                o, reset_info = w.reset()
                assert _fields(venv.reset_infos[i]["shield"]) == \
                    _fields(reset_info["shield"])
            assert o == obs[i]
    assert batches and max(batches) >= 32


def test_maskable_ppo_trains_on_a_shielded_vec_env():
    pytest.importorskip("sb3_contrib")
    from sb3_contrib import MaskablePPO
    from sb3_contrib.common.maskable.utils import get_action_masks
    from stable_baselines3.common.vec_env import DummyVecEnv

    from tracecheck.live.vector_sb3 import ShieldedVecEnv

    venv = ShieldedVecEnv(DummyVecEnv([_frozenlake()] * 4))
    model = MaskablePPO("MlpPolicy", venv, n_steps=32, batch_size=64, n_epochs=1, seed=0,
                        device="cpu")
    model.learn(256)
    obs = venv.reset()
    for _ in range(50):
        masks = get_action_masks(venv)
        assert masks.tolist() == venv.action_masks().tolist()
        actions, _ = model.predict(obs, action_masks=masks)
        obs, _, _, infos = venv.step(actions)
        assert not any(info["shield"]["replaced"] for info in infos)  # always allowed


REAL = """
MACHINE Ratio
VARIABLES x
INVARIANT x : REAL
INITIALISATION x := 1.0
OPERATIONS
  Up = SELECT 1.0 / x > 0.5 THEN skip END;
  Down = SELECT x > 0.0 THEN skip END
END
"""


def test_many_is_one_by_one_a_refusal_included(batches):
    machine = load_machine_text(REAL)
    states = [{"x": v} for v in (1.0, 3.0, 0.0, -0.0, 1.5, float("nan"), 3.0, 1.0)
              + tuple(np.linspace(0.25, 4.0, 40).tolist())]
    alone = [Decisions(machine, ("Up", "Down")).one(s) for s in states]
    together = Decisions(machine, ("Up", "Down")).many(states)
    assert [(d.allowed, d.problem) for d in together] == \
        [(d.allowed, d.problem) for d in alone]
    zero = alone[2]
    assert zero.allowed == () and "Up: " in zero.problem  # fails closed, says why
    assert alone[0].allowed == ("Up", "Down") and alone[1].allowed == ("Down",)
    assert not batches  # the batch met the refusal: every state one by one


def test_the_faster_way_is_taken():
    machine = load_machine_text(REAL)
    decisions = Decisions(machine, ("Up", "Down"))
    for k in range(40):
        decisions.many([{"x": v} for v in np.linspace(0.25 + k, 4.0 + k, 40).tolist()])
    cost = decisions._cost
    assert cost[True] is not None and cost[False] is not None
    assert decisions._prefer_batch() == (cost[True] < cost[False]) or \
        decisions._choices % 64 == 0


def test_batch_takes_the_states_a_row_at_a_time_equal(batches):
    machine = load_machine_text(REAL)
    decisions = Decisions(machine, ("Up", "Down"))
    states = [{"x": v} for v in np.linspace(0.5, 4.0, 50).tolist()]
    assert [d.allowed for d in decisions.many(states)] == \
        [Decisions(machine, ("Up", "Down")).one(s).allowed for s in states]
    assert batches == [50]


def test_memo_tells_apart_values_python_finds_equal():
    decisions = Decisions(load_machine_text(REAL), ("Up", "Down"))
    a = Elem("a")
    assert decisions._key({"x": 0.0}) is None and decisions._key({"x": float("nan")}) is None
    keys = [decisions._key({"f": FuncValue({a: v})}) for v in (1, True, 1.0)]
    assert len(set(keys)) == 3
    mixed = FuncValue({a: 1, Elem("b"): True})
    assert decisions._key({"f": mixed}) is None  # 1 and TRUE in one function
    assert decisions._key({"s": frozenset({"a"})}) != decisions._key({"s": frozenset({a})})


def test_vector_env_errors_say_what_to_do():
    adapter = get_adapter("frozenlake")
    with pytest.raises(InputError, match="sub-environment 0 .* has no ShieldWrapper"):
        ShieldedVectorEnv(gym.vector.SyncVectorEnv(
            [lambda: adapter.make_env(adapter.config(None))]))

    class Elsewhere(gym.vector.VectorEnv):  # sub-environments in other processes
        def __init__(self):
            self.num_envs = 1

    with pytest.raises(InputError, match="run in other processes") as caught:
        ShieldedVectorEnv(Elsewhere())
    assert "SyncVectorEnv, DummyVecEnv" in caught.value.hint
    other = _corridor(SHIELD.replace("pos > 1", "pos > 2"))
    with pytest.raises(InputError, match="different shields"):
        ShieldedVectorEnv(gym.vector.SyncVectorEnv([_corridor(), other]))
    assert ShieldedVectorEnv(gym.vector.SyncVectorEnv([_corridor(), _corridor()])).group


def test_continuous_sub_environments_are_refused():
    pytest.importorskip("Box2D")
    adapter = get_adapter("lunarlander-continuous")
    shield = load_shield(adapter.default_shield)
    with pytest.raises(InputError, match="continuous actions") as caught:
        ShieldedVectorEnv(gym.vector.SyncVectorEnv(
            [lambda: ShieldWrapper(adapter.make_env(adapter.config(None)), shield,
                                   adapter=adapter)]))
    assert "each ShieldWrapper decides its own" in caught.value.hint


def test_an_info_deep_copies_as_its_values_need():
    """SB3's vector environments deep-copy every step's infos: the B state's immutable values
    are shared, the dicts and the lists of names copied (a 64-cell map copied value by value
    made the shield 75 % of a MaskablePPO step)."""
    import copy

    env = _frozenlake()()
    _, info = env.reset(seed=0)
    _, _, _, _, info = env.step(1)
    copied = copy.deepcopy(info)
    assert copied == info and copied["b_state"] is not info["b_state"]
    assert copied["b_state"]["field"] is info["b_state"]["field"]  # a FuncValue: immutable
    assert copied["shield"]["allowed"] is not info["shield"]["allowed"]
    copied["shield"]["allowed"].append("x")
    assert "x" not in info["shield"]["allowed"]
    info["shield"]["extra"] = {"nested": [1]}  # anything else: deep-copied
    assert copy.deepcopy(info)["shield"]["extra"]["nested"] is not \
        info["shield"]["extra"]["nested"]


def test_an_action_the_machine_has_no_operation_for_is_never_allowed(batches):
    """One by one, an adapter's action that names no operation of the shield is never
    allowed (machine.enabled_in never lists it); the batch path did allow it (review)."""
    machine = load_machine_text(REAL)
    states = [{"x": v} for v in np.linspace(0.25, 4.0, 40).tolist()]
    alone = [Decisions(machine, ("Up", "Jump", "Down")).one(s) for s in states]
    together = Decisions(machine, ("Up", "Jump", "Down")).many(states)
    assert batches == [40]
    assert [d.allowed for d in together] == [d.allowed for d in alone]
    assert not any("Jump" in d.allowed for d in together)
    assert [d.mask.tolist()[1] for d in together] == [False] * 40


def test_an_integer_beyond_int64_takes_the_states_one_by_one(batches):
    machine = load_machine_text(REAL.replace("x : REAL", "x : INTEGER")
                                .replace("x := 1.0", "x := 1")
                                .replace("1.0 / x > 0.5", "x < 3")
                                .replace("x > 0.0", "x > 0"))
    states = [{"x": k} for k in range(40)] + [{"x": 2 ** 70}]
    together = Decisions(machine, ("Up", "Down")).many(states)
    assert [d.allowed for d in together] == \
        [Decisions(machine, ("Up", "Down")).one(s).allowed for s in states]
    assert together[-1].allowed == ("Down",) and not batches


def test_an_interrupted_batch_leaves_every_state_waiting(monkeypatch):
    """A batch that fails (Ctrl-C in a notebook) leaves the states waiting: the next mask
    is decided, never the state before's."""
    envs = ShieldedVectorEnv(gym.vector.SyncVectorEnv([_corridor(slip=False)] * 3))
    envs.reset(seed=[0, 1, 2])
    assert envs.action_masks().tolist() == [[True, True]] * 3  # in cell 2
    many = Decisions.many

    def interrupted(self, states):
        raise KeyboardInterrupt

    monkeypatch.setattr(Decisions, "many", interrupted)
    with pytest.raises(KeyboardInterrupt):
        envs.step(np.array([0, 0, 0]))  # Left
    monkeypatch.setattr(Decisions, "many", many)
    assert [w.state["pos"] for w in envs.group.wrappers] == [1, 1, 1]
    assert envs.action_masks().tolist() == [[False, True]] * 3  # in cell 1: not Left


def test_an_adapter_action_without_an_operation_is_refused_at_once():
    """Let through, the action would be blocked in every state, silently (a new user's
    misspelt action); the command line refused it already."""
    from tracecheck.live.vector_sb3 import ShieldedVecEnv

    class Misspelt(Corridor):
        actions = ("Left", "Rigth")

    with pytest.raises(InputError, match="FrozenLakeShield lacks Left, Right") as caught:
        ShieldWrapper(Corridor().make_env({"slip": True}), load_shield("frozenlake"),
                      adapter=Corridor())
    assert "name each of the environment's actions" in caught.value.hint
    corridor = _corridor()().shield
    with pytest.raises(InputError, match="CorridorShield lacks Rigth"):
        ShieldWrapper(Corridor().make_env({"slip": True}), corridor, adapter=Misspelt())
    with pytest.raises(InputError, match="takes a Stable-Baselines3 vector environment, not "
                                         "list"):
        ShieldedVecEnv([_corridor()])


def test_a_decision_is_of_its_own_state_alone():
    """A state without a variable the state before had is decided without it (the guard
    that reads it cannot be evaluated: its action is not allowed, and says why), never with
    the value the state before left behind — whatever came before, and memoised or not."""
    machine = load_machine_text(REAL.replace("VARIABLES x", "VARIABLES x, y")
                                .replace("x : REAL", "x : REAL & y : REAL")
                                .replace("x := 1.0", "x := 1.0 || y := 1.0")
                                .replace("x > 0.0", "y > 0.0"))
    decisions = Decisions(machine, ("Up", "Down"))
    assert decisions.one({"x": 1.0, "y": 1.0}).allowed == ("Up", "Down")
    alone = decisions.one({"x": 1.0})
    assert alone.allowed == ("Up",) and alone.problem.startswith("Down: ")
    assert Decisions(machine, ("Up", "Down")).one({"x": 1.0}).allowed == ("Up",)
