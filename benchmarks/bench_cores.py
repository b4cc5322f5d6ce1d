"""Benchmark: how recording and replay scale with cores — episodes/s and parallel efficiency at
1, 2, 4, … workers up to every core, each a fresh `tracecheck` process as a user runs it.

    python benchmarks/bench_cores.py [--max-workers N] [--frozenlake 800] [--highway 16]
        [--replay 100000] [--import-traces 1000] [--repeat 1] [--out DIR] [--cache DIR]

Four jobs (each skipped with 0):

- ``record --env frozenlake`` with the bundled Q-table under the frozenlake shield, slippery
  lake, Foxglove's channels as the CLI writes them (``--frozenlake`` episodes), and beside
  it a bare loop of the same lake and Q-table without tracecheck (the same seeds, in this
  process): its steps per second against record's with one worker (the whole process);
- ``record`` of the bundled highway agent under the paper shield (``--highway`` episodes;
  needs highway-env);
- ``replay --shield strict`` of one file of ``--replay`` episodes: the paper's 40 SimB traces
  round-robin where ``../shared/data/paper-traces`` is, else frozenlake episodes recorded
  here (built once into ``--cache`` and kept there: 10⁵ episodes take minutes to write);
- ``import simb`` of a folder of ``--import-traces`` SimB traces: the paper's round-robin,
  read with the bundled ``paper`` machine (``--model``: every state type-checked, as a
  project reads them), else frozenlake episodes recorded and exported here
  (``--env frozenlake``); the files written are checked to be the same at every number of
  workers (but the time they were written).

Each process runs with Python's bytecode cache (a recording's written by a first, untimed
run of 2 episodes), as an installed tracecheck has it. A recording's runs at each number of
workers are interleaved (1, 2, 1, 2, …: a shared machine whose speed drifts moves them
alike), each count's median and runs reported, and beside the ratio of the medians the
median of each round's own ratio ("paired": the runs of one round ran a few seconds apart,
where this machine's speed drifted by a third between sittings). Every run of a
job writes or reads the same episodes; the replay's JSON report is checked to be
the same at every number of workers (but its timing fields). Out: a table on stdout, and
``cores.json`` and ``cores.md`` in ``--out`` (default: the current folder). No network.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Optional

ROOT = Path(__file__).resolve().parents[1]
SIMB = ROOT.parent / "shared" / "data" / "paper-traces" / "simb"
TIMING = ("elapsed_s", "steps_per_s")


def counts(top: int) -> list[int]:
    """1, 2, 4, … below ``top``, and ``top``."""
    out, w = [], 1
    while w < top:
        out.append(w)
        w *= 2
    return out + [top]


#: the processes' environment: with Python's bytecode cache, as an installed tracecheck has
#: it, even where PYTHONDONTWRITEBYTECODE is set here (each process compiled every module of
#: tracecheck from source then: about 0.2 s of a recording's serial start)
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def tracecheck(*args: str) -> float:
    """Wall time of one fresh `tracecheck` process (it must succeed)."""
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "tracecheck", *args], capture_output=True,
                          text=True, env=ENV)
    took = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"tracecheck {' '.join(args)} failed ({done.returncode}):\n"
                         f"{done.stderr[-2000:]}")
    return took


def record_job(name: str, episodes: int, run: list[str], workers: list[int], repeat: int,
               tmp: Path) -> list[dict]:
    # the numbers of workers interleaved, repeat after repeat: a machine whose speed drifts
    # (a shared one) moves them alike, not one count's runs against another's
    times: dict[int, list[float]] = {w: [] for w in workers}
    tracecheck("record", *run, "--episodes", "2", "--seed", "0", "--workers", "1", "-o",
               str(tmp / f"{name}-warm.mcap"), "--force")  # the bytecode cache, untimed
    for _ in range(repeat):
        for w in workers:
            times[w].append(tracecheck("record", *run, "--episodes", str(episodes), "--seed",
                                       "0", "--workers", str(w), "-o",
                                       str(tmp / f"{name}-{w}.mcap"), "--force"))
    rows = []
    for w in workers:
        rows.append({"job": name, "workers": w, "episodes": episodes,
                     "seconds": statistics.median(times[w]),
                     "steps": _steps_in(tmp / f"{name}-{w}.mcap"),
                     "runs": [round(t, 3) for t in times[w]]})
        print(f"  {name}: {w} workers, {episodes} episodes in {rows[-1]['seconds']:.2f} s "
              f"(runs: {', '.join(f'{t:.2f}' for t in times[w])})", flush=True)
    return rows


def _steps_in(path: Path) -> int:
    """The agent's steps in a run file: its states less each episode's first."""
    from tracecheck.episodes.columns import read_columns

    run = read_columns(path)
    return run.n - len(run.episode_ids)


def bare_frozenlake(episodes: int, repeat: int) -> dict:
    """The environment and agent of ``record --env frozenlake`` without tracecheck: the same
    slippery lake (the adapter's own Gymnasium environment), ``argmax`` of the bundled
    Q-table, episode i from seed i, in a plain loop in this process (no start-up): its
    steps per second, the median of ``repeat`` runs. Unshielded, its episodes are not the
    recording's (the shield replaces some actions), so it is compared per step."""
    import numpy as np

    from tracecheck.live.adapter import get_adapter

    adapter = get_adapter("frozenlake")
    env = adapter.make_env(adapter.config({"is_slippery": True}))
    q = np.load(ROOT / "models" / "agents" / "frozenlake.npy")
    rates, steps = [], 0
    for _ in range(repeat):
        steps = 0
        start = time.perf_counter()
        for seed in range(episodes):
            obs, _ = env.reset(seed=seed)
            done = False
            while not done:
                obs, _, term, trunc, _ = env.step(int(np.argmax(q[obs])))
                steps += 1
                done = term or trunc
        rates.append(steps / (time.perf_counter() - start))
    return {"episodes": episodes, "steps": steps, "steps_per_s": statistics.median(rates)}


def replay_file(episodes: int, cache: Path) -> Path:
    """A file of ``episodes`` episodes (made once, kept in ``cache``)."""
    kind = "paper" if SIMB.is_dir() else "frozenlake"
    path = cache / f"cores-{kind}-{episodes}.mcap"
    if path.exists():
        return path
    cache.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    part = path.with_suffix(".part.mcap")
    if kind == "paper":
        import dataclasses
        from itertools import cycle, islice

        from tracecheck.episodes.files import write_run
        from tracecheck.episodes.writer import new_header
        from tracecheck.interop import import_simb
        from tracecheck.live.envs.highway import HIGHWAY

        sources = list(import_simb([SIMB / "base", SIMB / "base_shield"], vocab=HIGHWAY))
        eps = (dataclasses.replace(e, id=i) for i, e in enumerate(islice(cycle(sources),
                                                                        episodes)))
        write_run(part, new_header("imported-simb", variables=list(HIGHWAY.variables),
                                   actions=list(HIGHWAY.actions)), eps)
    else:
        tracecheck("record", *FROZENLAKE, "--episodes", str(episodes), "--seed", "0",
                   "--workers", str(os.cpu_count() or 1), "-o", str(part), "--force")
    part.rename(path)
    print(f"  made {path} ({episodes} episodes) in {time.perf_counter() - start:.0f} s",
          flush=True)
    return path


def replay_job(path: Path, shield: str, episodes: int, workers: list[int], repeat: int,
               tmp: Path) -> list[dict]:
    rows, first = [], None
    for w in workers:
        times = []
        for k in range(repeat):
            out = tmp / f"replay-{w}-{k}.json"
            start = time.perf_counter()
            with open(out, "w") as f:
                done = subprocess.run([sys.executable, "-m", "tracecheck", "replay", str(path),
                                       "--shield", shield, "--json", "--workers", str(w)],
                                      stdout=f, stderr=subprocess.PIPE, text=True, env=ENV)
            times.append(time.perf_counter() - start)
            if done.returncode not in (0, 1):
                raise SystemExit(f"replay failed ({done.returncode}): {done.stderr[-2000:]}")
            report = {k: v for k, v in json.loads(out.read_text()).items() if k not in TIMING}
            if first is None:
                first = report
            elif report != first:
                raise SystemExit(f"replay with {w} workers reports differently from 1 worker")
        rows.append({"job": f"replay {shield}", "workers": w, "episodes": episodes,
                     "seconds": statistics.median(times), "same_report": True})
        print(f"  replay: {w} workers, {episodes} episodes in {rows[-1]['seconds']:.2f} s "
              "(the same report)", flush=True)
    return rows


def import_folder(traces: int, cache: Path) -> tuple[Path, list[str]]:
    """A folder of ``traces`` SimB traces (made once, kept in ``cache``) and the options
    that read them."""
    kind = "paper" if SIMB.is_dir() else "frozenlake"
    folder = cache / f"cores-simb-{kind}-{traces}"
    env = ["--model", str(ROOT / "models" / "shields" / "paper.mch")] if kind == "paper" \
        else ["--env", "frozenlake"]
    if folder.is_dir():
        return folder, env
    part = folder.with_name(folder.name + ".part")
    part.mkdir(parents=True, exist_ok=True)
    if kind == "paper":
        sources = sorted(SIMB.glob("*/Timed_Simulation_*.json"))
        for k in range(traces):
            (part / f"Timed_Simulation_{k + 1}.json").symlink_to(sources[k % len(sources)])
    else:
        run = part / "run.mcap"
        tracecheck("record", *FROZENLAKE, "--episodes", str(traces), "--seed", "0",
                   "--workers", str(os.cpu_count() or 1), "-o", str(run), "--force")
        tracecheck("export", "simb", str(run), "-o", str(part / "simb"))
        for f in (part / "simb").iterdir():
            f.rename(part / f.name)
        (part / "simb").rmdir()
        run.unlink()
    part.rename(folder)
    return folder, env


def import_job(folder: Path, env: list[str], traces: int, workers: list[int], repeat: int,
               tmp: Path) -> list[dict]:
    rows, first = [], None
    for w in workers:
        times = []
        for k in range(repeat):
            out = tmp / f"import-{w}-{k}.mcap"
            times.append(tracecheck("import", "simb", str(folder), *env, "-o", str(out),
                                    "--workers", str(w)))
            episodes = _episodes_of(out)
            if first is None:
                first = episodes
            elif episodes != first:
                raise SystemExit(f"import with {w} workers wrote a different file")
            out.unlink()
        rows.append({"job": "import simb", "workers": w, "episodes": traces,
                     "seconds": statistics.median(times), "same_file": True})
        print(f"  import: {w} workers, {traces} traces in {rows[-1]['seconds']:.2f} s "
              "(the same file)", flush=True)
    return rows


def _episodes_of(path: Path) -> list:
    """A run file's messages and attachments but the run header's creation time, and times
    relative to the file's first message: what two imports of the same traces share."""
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        reader = make_reader(f)
        out, clock = [], None
        for _, channel, message in reader.iter_messages(log_time_order=False):
            clock = message.log_time if clock is None else clock
            data = message.data
            if channel.topic == "/tracecheck/run":
                header = json.loads(data)
                header.pop("created", None)
                data = json.dumps(header).encode()
            out.append((channel.topic, message.log_time - clock, data))
    return out


FROZENLAKE = ["--env", "frozenlake", "--env-config", "is_slippery=true",
              "--agent", str(ROOT / "models" / "agents" / "frozenlake.npy"),
              "--shield", "frozenlake"]
HIGHWAY_RUN = ["--agent", str(ROOT / "models" / "agents" / "base.zip"), "--shield", "paper"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--frozenlake", type=int, default=800)
    parser.add_argument("--highway", type=int, default=16)
    parser.add_argument("--replay", type=int, default=100_000)
    parser.add_argument("--import-traces", type=int, default=1000)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--out", type=Path, default=Path("."))
    parser.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "tracecheck-bench")
    args = parser.parse_args()
    workers = counts(args.max_workers)
    print(f"{os.cpu_count()} cores; workers {workers}; medians of {args.repeat}", flush=True)
    rows: list[dict] = []
    bare: Optional[dict] = None
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if args.frozenlake:
            rows += record_job("record frozenlake", args.frozenlake, FROZENLAKE, workers,
                               args.repeat, tmp)
            bare = bare_frozenlake(args.frozenlake, args.repeat)
            one = next(r for r in rows if r["job"] == "record frozenlake" and r["workers"] == 1)
            bare["record_steps_per_s"] = one["steps"] / one["seconds"]
            bare["ratio"] = bare["record_steps_per_s"] / bare["steps_per_s"]
            print(f"  bare loop (the lake and the Q-table, no tracecheck): "
                  f"{bare['steps_per_s']:,.0f} steps/s; record with 1 worker "
                  f"{bare['record_steps_per_s']:,.0f} steps/s, the whole process "
                  f"(1/{1 / bare['ratio']:.0f} of the bare loop)", flush=True)
        if args.highway:
            try:
                import highway_env  # noqa: F401
            except ImportError:
                print("  record highway: skipped (highway-env is not installed)")
            else:
                rows += record_job("record highway", args.highway, HIGHWAY_RUN, workers,
                                   args.repeat, tmp)
        if args.replay:
            path = replay_file(args.replay, args.cache)
            shield = "strict" if SIMB.is_dir() else "frozenlake"
            rows += replay_job(path, shield, args.replay, workers, args.repeat, tmp)
        if args.import_traces:
            folder, env = import_folder(args.import_traces, args.cache)
            rows += import_job(folder, env, args.import_traces, workers, args.repeat, tmp)
    for row in rows:
        one = next(r for r in rows if r["job"] == row["job"] and r["workers"] == 1)
        row["episodes_per_s"] = round(row["episodes"] / row["seconds"], 2)
        row["speedup"] = round(one["seconds"] / row["seconds"], 3)
        row["efficiency"] = round(row["speedup"] / row["workers"], 3)
        if "runs" in row:  # interleaved: each round's own ratio, their median
            row["paired_speedup"] = round(statistics.median(
                a / b for a, b in zip(one["runs"], row["runs"])), 3)
    machine = {"cores": os.cpu_count(), "python": sys.version.split()[0],
               "repeat": args.repeat}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "cores.json").write_text(json.dumps({"machine": machine, "rows": rows,
                                                     "bare_frozenlake": bare},
                                                    indent=2) + "\n")
    table = ["| job | workers | episodes | seconds | episodes/s | speed-up | efficiency | "
             "speed-up, paired |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    table += [f"| {r['job']} | {r['workers']} | {r['episodes']} | {r['seconds']:.2f} | "
              f"{r['episodes_per_s']} | {r['speedup']:.2f}× | {r['efficiency']:.0%} | "
              + (f"{r['paired_speedup']:.2f}× |" if "paired_speedup" in r else "- |")
              for r in rows]
    text = f"{machine['cores']} cores, medians of {args.repeat}\n\n" + "\n".join(table) + "\n"
    if bare is not None:
        text += (f"\nA bare loop of the lake and the Q-table: {bare['steps_per_s']:,.0f} steps/s; "
                 f"record with 1 worker (the whole process): {bare['record_steps_per_s']:,.0f} "
                 f"steps/s, {bare['ratio']:.3f} of it.\n")
    (args.out / "cores.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
