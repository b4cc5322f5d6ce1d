"""The JSON schemas in schemas/ are the ones the code writes into every file."""

from __future__ import annotations

from tests.helpers import ROOT
from tracecheck.episodes import schema


def test_exported_schemas_are_current(tmp_path):
    written = schema.export_schemas(tmp_path)
    assert {p.name for p in written} == {f"{n}.json" for n in schema.MESSAGES}
    for path in written:
        committed = ROOT / "schemas" / path.name
        assert committed.exists(), f"{committed} is missing: run python -m tracecheck.episodes.schema"
        assert committed.read_text() == path.read_text(), (
            f"{committed} is stale: run python -m tracecheck.episodes.schema")


def test_step_schema_names_the_live_fields():
    props = schema.StepMessage.model_json_schema()["properties"]
    for field in ("time", "action", "state", "reward", "crashed", "observation",
                  "action_values", "preferred_action", "allowed_actions", "shield_time_us"):
        assert field in props
