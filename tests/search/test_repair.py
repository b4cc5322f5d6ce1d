"""tracecheck repair: on shields weakened in one number so that a recorded crash is no longer
blocked, the smallest change that blocks it again is found, and the repaired machine proves
deadlock-free as the original does."""

from __future__ import annotations

import dataclasses
import math

import pytest

from tests.helpers import run
from tracecheck.b.threshold import values_of
from tracecheck.checking.replaying import replay
from tracecheck.checking.shield import load_shield
from tracecheck.episodes.files import write_run
from tracecheck.episodes.model import make_end
from tracecheck.episodes.reader import read_run
from tracecheck.episodes.writer import new_header
from tracecheck.errors import InputError
from tracecheck.interop import import_simb
from tracecheck.live.envs.highway import HIGHWAY
from tracecheck.search.repair import find_gap, repair
from tracecheck.search.tune_target import resolve_target
from tracecheck.search.tuning import shield_with


@pytest.fixture(scope="module")
def crashes(tmp_path_factory, paper_traces):
    """The paper's unshielded traces, each crashed one cut at the first step the paper's
    shield blocks and made to crash there: every crash blocked at its own step."""
    folder = tmp_path_factory.mktemp("repair")
    header = new_header("imported-simb", variables=list(HIGHWAY.variables),
                        actions=list(HIGHWAY.actions))
    whole = folder / "base.mcap"
    write_run(whole, header, import_simb([paper_traces / "simb" / "base"], vocab=HIGHWAY))
    first = {e.episode: e.first_infeasible for e in replay([whole], load_shield("paper")).per_episode
             if e.crashed}
    cut = []
    for ep in read_run(whole).episodes:
        if ep.id in first:
            k = first[ep.id]
            steps = tuple(ep.steps[:k]) + (dataclasses.replace(ep.steps[k], crashed=True),)
            cut.append(dataclasses.replace(ep, steps=steps, end=make_end(steps)))
    path = folder / "cut.mcap"
    write_run(path, header, cut)
    return path


def _weakenings(path, shield, most: int) -> list:
    """(episode, literal spec, weakened value): a number of the blocked action's guard moved
    just far enough that the guard allows the crash step, and no earlier step is blocked."""
    cols_report = replay([path], shield)
    found = []
    for e in cols_report.per_episode:
        op = shield.machine.operations[e.action]
        run_ = read_run(path, only={e.episode}).episodes[0]
        state = run_.steps[e.crash_step - 1].state
        numbers = {}
        for n in _numbers(op.guard):
            numbers.setdefault((n.pos.line, n.pos.column), n)
        for (line, col), node in sorted(numbers.items()):
            value = node.value if hasattr(node, "value") else -node.operand.value
            spec = f"{e.action}:{value}@{line}:{col}"
            target = resolve_target(shield.machine, literal=spec)
            allowed = values_of(shield.machine, target.guards[e.action], target.name, state)
            pieces = allowed.intervals()
            if allowed.empty or allowed.contains(value) or not pieces:
                continue
            lo, hi, _, _ = min(pieces, key=lambda p: min(abs(float(x) - value) for x in p[:2]
                                                         if x is not None))
            inside = [float(x) for x in (lo, hi) if x is not None]
            near = min(inside, key=lambda x: abs(x - value))
            far = next((x for x in inside if x != near), near + math.copysign(2.0, near - value))
            weak_value = near + (far - near) / 4
            weak = shield_with(shield, target, weak_value)
            again = [x for x in replay([path], weak).per_episode if x.episode == e.episode][0]
            if again.first_infeasible is None:
                found.append((e.episode, e.crash_step, spec, target, weak_value, weak))
            if len(found) == most:
                return found
    return found


def _numbers(node) -> list:
    from tracecheck.b import ast

    out = []

    def walk(n):
        if isinstance(n, ast.Neg) and isinstance(n.operand, (ast.RealLit, ast.IntLit)):
            out.append(n)  # -15.0 is one number
            return
        if isinstance(n, (ast.RealLit, ast.IntLit)) and n.pos is not None:
            out.append(n)
        for c in ast.children(n):
            walk(c)
    walk(node)
    return out


def test_repair_recovers_the_smallest_blocking_value_of_ten_injected_weakenings(crashes):
    paper = load_shield("paper")
    cases = _weakenings(crashes, paper, 10)
    assert len(cases) >= 10
    for episode, step, spec, _target, weak_value, weak in cases:
        line, col = map(int, spec.rpartition("@")[2].split(":"))
        col += weak_value < 0  # written (-x): the number starts after the parenthesis
        weak_spec = f"{spec.partition(':')[0]}:{weak_value!r}@{line}:{col}"
        gap = find_gap([str(crashes)], weak, episode=episode)
        assert (gap.step, gap.action) == (step, spec.partition(":")[0])
        result = repair([str(crashes)], weak, gap, literals=[weak_spec], timeout_s=20)
        v = result.chosen.value
        weak_target = resolve_target(weak.machine, literal=weak_spec)
        blocked = [x for x in replay([crashes], shield_with(weak, weak_target, v)).per_episode
                   if x.episode == episode][0]
        assert blocked.first_infeasible == step, (spec, v)
        closer = math.nextafter(v, weak_value)
        open_ = [x for x in replay([crashes], shield_with(weak, weak_target, closer)).per_episode
                 if x.episode == episode][0]
        assert open_.first_infeasible is None, (spec, v, closer)  # nothing nearer blocks it
        assert result.deadlock_free == {"original": "proved", "repaired": "proved"}, spec
        assert result.newly_blocked >= 1
        assert any(s["status"] == "counterexample" for s in result.symbolic)


def test_a_crash_already_blocked_or_no_crash_is_refused(crashes):
    paper = load_shield("paper")
    with pytest.raises(InputError, match="already blocks step"):
        find_gap([str(crashes)], paper, episode=2)
    with pytest.raises(InputError, match="no episode 999"):
        find_gap([str(crashes)], paper, episode=999)


def test_a_number_that_cannot_block_it_is_said_so(crashes):
    paper = load_shield("paper")
    episode, step, spec, target, weak_value, weak = _weakenings(crashes, paper, 1)[0]
    gap = find_gap([str(crashes)], weak, episode=episode)
    result = repair([str(crashes)], weak, gap, literals=["SLOWER:10.0"], timeout_s=5)
    assert result.chosen is None
    assert "does not read it" in result.candidates[0].why


def test_repair_on_the_command_line_writes_the_repaired_machine(crashes, capsys, tmp_path):
    paper = load_shield("paper")
    episode, step, spec, target, weak_value, weak = _weakenings(crashes, paper, 1)[0]
    weak_file = tmp_path / "weak.mch"
    weak_file.write_text(weak.machine.source)
    out = tmp_path / "fixed.mch"
    code, stdout, err = run(capsys, "repair", crashes, "-s", weak_file, "--episode", episode,
                            "-o", out)
    assert code == 0, err
    assert "<- the smallest change" in stdout and "deadlock-free: original proved, " \
        "repaired proved" in stdout
    assert out.read_text() != weak_file.read_text()
    code, stdout, err = run(capsys, "repair", crashes, "-s", weak_file, "--episode", episode,
                            "-o", out)
    assert code == 2 and "exists" in err
    code, stdout, err = run(capsys, "repair", crashes, "-s", weak_file, "-o", tmp_path / "x.txt")
    assert code == 2 and "is a .mch file" in err
