"""tracecheck installed as a wheel works outside the source tree: built-in shields, bundled
agents and property sets come from the installed package data."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys

import pytest

from tests.helpers import ROOT


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """The wheel of this checkout, installed (without its dependencies, which the test
    environment has) into a folder of its own."""
    folder = tmp_path_factory.mktemp("wheel")
    build = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "--no-build-isolation",
         "-w", str(folder / "dist"), str(ROOT)], capture_output=True, text=True, timeout=300)
    if build.returncode != 0 and "No module named setuptools" in build.stderr:
        pytest.skip("setuptools is not installed here, so no wheel can be built offline")
    assert build.returncode == 0, build.stderr
    (wheel,) = (folder / "dist").glob("tracecheck-*.whl")
    site = folder / "site"
    install = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-index",
         "--target", str(site), str(wheel)], capture_output=True, text=True, timeout=300)
    assert install.returncode == 0, install.stderr
    shutil.rmtree(ROOT / "build", ignore_errors=True)
    return site


def tracecheck(site, cwd, *args) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(site))
    return subprocess.run([sys.executable, "-m", "tracecheck.cli", *map(str, args)], cwd=cwd,
                          env=env, capture_output=True, text=True, timeout=300)


def test_the_wheel_runs_outside_the_source_tree(installed, tmp_path):
    run = tmp_path / "base_none.mcap"
    shutil.copy(ROOT / "sample_traces" / "base_none.mcap", run)
    where = subprocess.run([sys.executable, "-c", "import tracecheck; print(tracecheck.__file__)"],
                           cwd=tmp_path, env=dict(os.environ, PYTHONPATH=str(installed)),
                           capture_output=True, text=True)
    assert where.stdout.startswith(str(installed)), where.stdout + where.stderr
    result = tracecheck(installed, tmp_path, "replay", run, "--shield", "paper")
    assert result.returncode == 0, result.stderr
    assert "Replay against shield paper" in result.stdout
    for shield in ("strict", "none", "frozenlake", "cliffwalking", "highway_continuous",
                   "lunarlander_continuous"):
        checked = tracecheck(installed, tmp_path, "check-model", shield)
        assert checked.returncode == 0 and "ok:" in checked.stdout, checked.stderr


def test_the_wheel_records_with_a_bundled_agent(installed, tmp_path):
    from tracecheck.checking.shield import data_dir

    agent = data_dir() / "agents" / "frozenlake.npy"
    out = tmp_path / "fl.mcap"
    result = tracecheck(installed, tmp_path, "record", "--env", "frozenlake", "--agent", agent,
                        "--shield", "frozenlake", "-n", 2, "-o", out)
    assert result.returncode == 0, result.stderr
    stats = tracecheck(installed, tmp_path, "stats", out)
    assert stats.returncode == 0 and "GOAL" in stats.stdout, stats.stderr
