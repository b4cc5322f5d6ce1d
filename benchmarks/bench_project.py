"""``tracecheck project`` on a ProB2-UI project of the authors' shape, against importing its
traces once.

The authors' ``HighwayEnvironment.prob2project`` (hhu-stups/reinforcement-learning-b-models)
has, per machine, a folder of 1000 SimB timed traces of the base agent (``Traces_Base``) and
one of the higher-penalty agent (``Traces_Higher_Penalty_Collision``), each with eleven
SimB tasks (hypothesis tests and estimations of ``Crash = FALSE``, the speed, the reward,
the distance, the accelerations, the vehicles around, the right lane). This builds that
project in a temporary folder: the two folders linked round-robin from the paper's SimB
traces (``../shared/data/paper-traces/simb`` or ``--traces DIR``: base/ and base_shield/),
the bundled ``paper`` and ``strict`` machines as two machines of the project, each with the
22 tasks (44 in all, and two Monte Carlo tasks per machine) — and times, as fresh processes
(wall time, medians of interleaved runs):

* ``tracecheck project PROJECT --no-scripts --json`` (every task run);
* ``tracecheck import simb`` of the two folders, one after the other (the baseline: reading
  the traces once).

Issue 46's target: the project at most 2× the import.

    python benchmarks/bench_project.py [--traces N] [--repeat 3] [--source DIR]
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCE = ROOT.parent / "shared" / "data" / "paper-traces" / "simb"
SPEED = ("RSQRT(VehiclesVy(EgoVehicle) * VehiclesVy(EgoVehicle) + VehiclesVx(EgoVehicle) * "
         "VehiclesVx(EgoVehicle))")
ACCEL = ("RSQRT(VehiclesAy(EgoVehicle) * VehiclesAy(EgoVehicle) + VehiclesAx(EgoVehicle) * "
         "VehiclesAx(EgoVehicle))")


def _test(predicate: str, probability: float, significance: float = 0.01) -> dict:
    return {"type": "HYPOTHESIS_TEST", "information": {
        "SIGNIFICANCE": significance, "PROBABILITY": probability,
        "MAX_STEPS_BEFORE_PROPERTY": 0, "PREDICATE": predicate, "ENDING_TIME": 60000,
        "HYPOTHESIS_CHECKING_TYPE": "LEFT_TAILED", "CHECKING_TYPE": "PREDICATE_INVARIANT"}}


def _estimate(expression: str, desired: float, checking: str, epsilon: float) -> dict:
    return {"type": "ESTIMATION", "information": {
        "MAX_STEPS_BEFORE_PROPERTY": 0, "ESTIMATION_TYPE": "MEAN", "ENDING_TIME": 60000,
        "EXPRESSION": expression, "DESIRED_VALUE": desired, "CHECKING_TYPE": checking,
        "EPSILON": epsilon}}


def tasks() -> list[dict]:
    """The eleven tasks the authors' project runs on each folder of traces."""
    near = ("not(#v. (v : Vehicles \\ {EgoVehicle} & VehiclesX(v) >= -15.0 & VehiclesX(v) "
            "<= 15.0  & VehiclesY(v) >= -4.0 & VehiclesY(v) <= 4.0))")
    same = ("Crash = FALSE => not(#v. (v : Vehicles \\ {EgoVehicle} & VehiclesX(v) < 0.01 & "
            "VehiclesX(v) > -0.01 & VehiclesY(v) < 0.01 & VehiclesY(v) > -0.01))")
    return [
        _test("Crash = FALSE", 0.95),
        _estimate(SPEED, 25.0, "AVERAGE", 5.0),
        _estimate("Reward", 40.0, "SUM", 20.0),
        _estimate("VehiclesVx(EgoVehicle)", 1500.0, "SUM", 300.0),
        _test(f"Crash = FALSE => (VehiclesAx(EgoVehicle) < 0.0 => {ACCEL} <= 5.0)", 0.7),
        _test(f"Crash = FALSE => (VehiclesAx(EgoVehicle) > 0.0 => {ACCEL} <= 5.0)", 0.7),
        _test(f"Crash = FALSE => ({SPEED} >= 20.0)", 0.7),
        _test(f"Crash = FALSE => ({SPEED} <= 30.0)", 0.7),
        _test(near, 0.95),
        _test(same, 0.999, 0.001),
        _estimate("IF VehiclesY(EgoVehicle) >= 7.0 THEN 1.0 ELSE 0.0 END", 30.0, "SUM", 30.0),
    ]


FOLDERS = {"Traces_Base": "base", "Traces_Higher_Penalty_Collision": "base_shield"}


def build(folder: Path, n: int, source: Path) -> Path:
    """The project in ``folder`` with ``n`` traces per folder; its path."""
    for name, sub in FOLDERS.items():
        files = sorted((source / sub).glob("Timed_Simulation_*.json"))
        if not files:
            sys.exit(f"no SimB traces in {source / sub}: give --source DIR (with base/ and "
                     "base_shield/ of Timed_Simulation_*.json)")
        out = folder / name
        out.mkdir(parents=True)
        for k in range(n):
            (out / f"Timed_Simulation_{k + 1}.json").symlink_to(files[k % len(files)])
    machines = []
    for shield in ("paper", "strict"):
        shutil.copy(ROOT / "models" / "shields" / f"{shield}.mch", folder / f"{shield}.mch")
        simulations = [{"path": name, "simulationItems": [
            {"id": None, **t} for t in tasks()]} for name in FOLDERS]
        machines.append({"name": shield, "description": "", "location": f"{shield}.mch",
                         "lastUsedPreferenceName": "default", "simulations": simulations})
    project = folder / "Highway.prob2project"
    project.write_text(json.dumps({"name": "Highway", "description": "", "machines": machines,
                                   "preferences": [], "metadata": {"fileType": "Project",
                                                                  "formatVersion": 10}}))
    return project


def _time(cmd: list[str]) -> float:
    start = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True)
    spent = time.perf_counter() - start
    if done.returncode not in (0, 1, 3):
        sys.exit(f"{' '.join(cmd)} failed ({done.returncode}):\n{done.stderr[-2000:]}")
    return spent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--traces", type=int, default=1000, help="traces per folder")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--source", type=Path, default=SOURCE)
    args = parser.parse_args()
    cli = [sys.executable, "-m", "tracecheck"]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        project = build(folder / "project", args.traces, args.source)
        report = subprocess.run(cli + ["project", str(project), "--no-scripts", "--json"],
                                capture_output=True, text=True)
        rows = json.loads(report.stdout)["tasks"] if report.stdout.strip() else []
        statuses = [r["status"] for r in rows]
        print(f"{len(rows)} tasks: " + ", ".join(f"{statuses.count(s)} {s}"
                                                 for s in sorted(set(statuses))))
        times: dict[str, list[float]] = {"project": [], "import": []}
        for k in range(args.repeat):
            times["project"].append(_time(cli + ["project", str(project), "--no-scripts",
                                                 "--json"]))
            spent = 0.0
            for name in FOLDERS:
                out = folder / f"import-{k}-{name}.mcap"
                spent += _time(cli + ["import", "simb", str(project.parent / name),
                                      "--model", str(folder / "project" / "paper.mch"), "-o",
                                      str(out)])
                out.unlink(missing_ok=True)
            times["import"].append(spent)
        med = {k: statistics.median(v) for k, v in times.items()}
        ratio = med["project"] / med["import"]
        print(f"project ({len(rows)} tasks, 2 machines, 2 folders of {args.traces} traces): "
              f"{med['project']:.1f} s; import simb of the two folders: {med['import']:.1f} s "
              f"(medians of {args.repeat}) — {ratio:.2f}×")
        print(f"issue 46: project <= 2× one import of the two folders: "
              f"{'met' if ratio <= 2 else 'NOT met'}")


if __name__ == "__main__":
    main()
