"""What a machine loaded by itself and a shield's machine answer where a guard is not linear
in its REAL parameters: explicitly different types (the solver was injected after loading,
so the same file answered differently by how it was loaded)."""

from __future__ import annotations

import pytest

from tracecheck.b.machine import Machine, load_machine
from tracecheck.checking.shield import ShieldMachine, load_shield
from tracecheck.errors import UnsupportedError

pytest.importorskip("z3")

SQUARE = """MACHINE Square
VARIABLES x
INVARIANT x : REAL
INITIALISATION x := 0.0
OPERATIONS
  Act(a) = PRE a : REAL & a * a <= x THEN skip END
END
"""


def test_a_plain_machine_refuses_where_a_shields_machine_asks_the_solver(tmp_path):
    path = tmp_path / "square.mch"
    path.write_text(SQUARE)
    plain, shield = load_machine(path), load_shield(path).machine
    assert type(plain) is Machine and isinstance(shield, ShieldMachine)
    with pytest.raises(UnsupportedError):
        plain.allowed("Act", {"x": 4.0})
    allowed = shield.allowed("Act", {"x": 4.0})
    assert allowed.contains({"a": 1.5}) and not allowed.contains({"a": 2.5})
    assert load_machine(path, kind=ShieldMachine).allowed("Act", {"x": 4.0}).contains({"a": 2.0})


def test_the_shield_machine_survives_pickling(tmp_path):
    import pickle

    path = tmp_path / "square.mch"
    path.write_text(SQUARE)
    again = pickle.loads(pickle.dumps(load_shield(path)))
    assert isinstance(again.machine, ShieldMachine)
    assert again.machine.allowed("Act", {"x": 1.0}).contains({"a": -1.0})


def test_a_run_whose_states_have_another_type_than_the_shield_declares_is_refused(tmp_path):
    """A REAL where the shield declares INTEGER (a new user's adapter gave floats): replay
    judged the guards on values the shield cannot have and answered with exit 0."""
    from tracecheck.checking.replaying import replay
    from tracecheck.episodes import EpisodeWriter, new_header
    from tracecheck.episodes.model import Episode, StepRecord, make_end
    from tracecheck.errors import InputError

    shield_path = tmp_path / "tank.mch"
    shield_path.write_text("MACHINE Tank VARIABLES level INVARIANT level : 0..10 "
                           "INITIALISATION level := 0 OPERATIONS Fill = SELECT level < 9 THEN "
                           "level := level + 1 END END")
    steps = tuple(StepRecord(step=k, time=float(k), action=None if k == 0 else "Fill",
                             state={"level": float(k)}, reward=0.0, crashed=False)
                  for k in range(3))
    run = tmp_path / "tank.mcap"
    with EpisodeWriter(run, new_header("recorded", variables=["level"],
                                       actions=["Fill"])) as out:
        out.write(Episode(id=0, steps=steps, end=make_end(steps), seed=0))
    with pytest.raises(InputError, match="the states give level as a REAL .* but the shield "
                                         "tank declares it INTEGER"):
        replay([run], load_shield(shield_path))


def test_a_first_state_without_a_declared_variable_is_refused_before_any_episode(tmp_path):
    """state() that leaves out a variable the adapter declares: the recording went on, and
    only replay refused the file ('the states have no LeadSpeed')."""
    from tests.live.toy import CRUISE_SHIELD, Cruise
    from tracecheck.checking.shield import check_vocabulary
    from tracecheck.errors import InputError

    class Forgetful(Cruise):
        def state(self, obs, info, reward, env, initial):
            return {k: v for k, v in super().state(obs, info, reward, env, initial).items()
                    if k != "LeadSpeed"}

    path = tmp_path / "cruise.mch"
    path.write_text(CRUISE_SHIELD)
    adapter = Forgetful()
    with pytest.raises(InputError, match=r"state\(\) of the adapter cruise \(the first state\) gives no value for "
                                         "LeadSpeed, a variable the adapter declares"):
        check_vocabulary(load_shield(path), adapter, adapter.make_env({}))
