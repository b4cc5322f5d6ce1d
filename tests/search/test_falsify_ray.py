"""falsify on Ray (``--executor ray``): the same episodes as local workers asked the same
batches, and the CLI takes the option."""

from __future__ import annotations

import json

import pytest

from tests.helpers import ROOT, run
from tracecheck.episodes.reader import read_run
from tracecheck.live.rollout import RecordSettings
from tracecheck.search.falsify import FalsifySettings, falsify

pytest.importorskip("gymnasium")
ray = pytest.importorskip("ray", reason="the ray extra is not installed (pip install "
                                        "-e '.[ray]')")

AGENT = ROOT / "models" / "agents" / "frozenlake.npy"
PROPERTY = "G({not(x = 3 & y = 3)})"


def _episodes(path):
    return [(ep.id, ep.seed, ep.config, ep.search, [s.state for s in ep.steps])
            for ep in read_run(path).episodes]


def test_ray_gives_the_episodes_of_local_workers(local_ray, tmp_path):
    # TPE is told the values of each batch of 2 before it asks again: the same batches
    # (2 workers) give the same points, and so the same episodes, on either executor
    runs = {}
    for executor in ("local", "ray"):
        settings = FalsifySettings(
            RecordSettings(agent=str(AGENT), shield="frozenlake", episodes=1,
                           env="frozenlake", workers=2, executor=executor),
            ("seed=0..9999", "is_slippery={True,False}"), PROPERTY, budget=6,
            optimizer="tpe", baseline=True)
        result = falsify(settings, tmp_path / f"{executor}.mcap")
        runs[executor] = (_episodes(tmp_path / f"{executor}.mcap"), result.summaries)
    assert len(runs["ray"][0]) == 12
    assert runs["ray"] == runs["local"]


def test_the_cli_runs_a_search_on_ray(local_ray, tmp_path, capsys):
    out = tmp_path / "f.mcap"
    code, text, err = run(capsys, "falsify", "--agent", AGENT, "--env", "frozenlake",
                          "--shield", "frozenlake", "--param", "seed=0..999", "--property",
                          PROPERTY, "--budget", 4, "--optimizer", "halton", "--no-baseline",
                          "--executor", "ray", "--workers", 2, "-o", out, "--json")
    assert code == 0, err
    data = json.loads(text)
    assert data["optimizers"][0]["evaluations"] == 4
    assert [ep.search.evaluation for ep in read_run(out).episodes] == [0, 1, 2, 3]
