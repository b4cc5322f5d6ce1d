"""What two new users met in their first hour (issue 42): each message names the place and
the fix, a closed pipe is not a finding."""

from __future__ import annotations

import os
import subprocess
import sys

from tests.helpers import ROOT, run

UNTYPED = """MACHINE Untyped
VARIABLES V
INVARIANT V : REAL
INITIALISATION V := 0.0
OPERATIONS
    PUSH(u) = PRE V + u <= 10.0 THEN skip END
END
"""


def test_a_real_parameter_without_its_type_is_said_where_the_machine_is_checked(capsys, tmp_path):
    model = tmp_path / "untyped.mch"
    model.write_text(UNTYPED)
    code, out, err = run(capsys, "check-model", model)
    assert code == 0 and "ok: 1 operation(s)" in out
    assert ("warning: " + str(model) + ": the parameter u of PUSH is a REAL by its use, but its "
            "guard does not type it: add `u : REAL`") in " ".join(err.split())
    state = tmp_path / "s.json"
    state.write_text('{"V": "1.0"}')
    code, _, err = run(capsys, "guards", model, "-s", state)
    assert code == 2 and "cannot enumerate" not in err
    assert "the parameter u of PUSH is a REAL by its use" in err and "add `u : REAL`" in err
    model.write_text(UNTYPED.replace("PRE V + u", "PRE u : REAL & V + u"))
    code, _, err = run(capsys, "check-model", model)
    assert code == 0 and "warning" not in err


def test_a_closed_pipe_is_not_the_exit_code_of_a_change(tmp_path):
    """`tracecheck diff … | head` exited 1, the code --fail-on-change gives a change."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    reader = subprocess.Popen([sys.executable, "-m", "tracecheck", "envs"], cwd=tmp_path,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    reader.stdout.close()  # the reader stops before the first line
    reader.wait(timeout=60)
    assert reader.returncode == 141, reader.stderr.read()
