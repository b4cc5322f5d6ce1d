"""A metric whose expression gives no number is a located error, not a traceback."""

from __future__ import annotations

from tests.helpers import ROOT, run


def test_a_metric_that_is_no_number_is_refused_with_its_place(capsys, tmp_path):
    props = tmp_path / "p.toml"
    props.write_text('[metrics]\nlow = { expression = "{Crash}", aggregate = "min" }\n')
    code, _, err = run(capsys, "stats", ROOT / "sample_traces" / "base_none.mcap",
                       "--properties", props)
    assert code == 2 and "metric low" in err and "episode 0, step 0" in err
    assert "the value of `{Crash}` is frozenset({False}), not a number" in err
