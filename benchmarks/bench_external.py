"""What tracecheck's side of SimB's external-simulation protocol costs per step.

An agent script that does no work (it walks a FrozenLake map and answers at once, in the
shape of the authors' FrozenLake.py: five variables, the 64-cell map in every predicate) is
run for EPISODES episodes twice per repetition, interleaved:

* **baseline**: a bare ProB side in this script — the same requests and answers over the
  same socket, JSON only, no B: what the protocol itself costs;
* **tracecheck**: ``external_episodes`` with the frozenlake shield — each step's enabled
  operations, the predicate parsed and type-checked, the successor found and checked.

Prints the medians per step (wall time: the script's work and the socket's included) and
their ratio, the CPU time per step of this process alone — tracecheck's side, without the
script's — and the peak memory of this process. The script is started once per run (a
Python start-up, about 20 ms, is included in both wall times).

    python benchmarks/bench_external.py [--episodes 200] [--repeat 5]
"""

from __future__ import annotations

import argparse
import json
import resource
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tracecheck.checking import load_shield
from tracecheck.live.external import ExternalSettings, external_episodes

SCRIPT = r'''
import json, socket, sys
HOLES = {(3, 2), (5, 3), (3, 4), (1, 5), (2, 5), (6, 5), (1, 6), (4, 6), (6, 6), (3, 7)}
FIELD = "{" + ", ".join(f"({x} |-> {y}) |-> {'HOLE' if (x, y) in HOLES else 'ICE'}"
                        for y in range(8) for x in range(8)) + "}"
PATH = [(1, 0), (2, 0), (3, 0), (4, 0), (5, 0), (6, 0), (7, 0), (7, 1), (7, 2), (7, 3),
        (7, 4), (7, 5), (7, 6), (7, 7)]
sock = socket.create_connection(("127.0.0.1", int(sys.argv[-1])))
stream = sock.makefile("rwb")
def send(op, x, y, done):
    pred = f"x = {x} & y = {y} & goal_x = 7 & goal_y = 7 & field = {FIELD}"
    stream.write((json.dumps({"op": op, "delta": 1000, "predicate": pred,
                              "done": "true" if done else "false"}) + "\n").encode())
    stream.flush()
while True:
    line = stream.readline()
    if not line or json.loads(line)["finished"]:
        break
    send("$initialise_machine", 0, 0, False)
    for k, (x, y) in enumerate(PATH):
        line = stream.readline()
        if not line or json.loads(line)["finished"]:
            break
        send("Move_Right" if k < 6 else "Move_Down", x, y, k == len(PATH) - 1)
'''


def baseline(script: Path, episodes: int) -> tuple[float, float, int]:
    """The protocol alone: (seconds, CPU seconds of this process, steps)."""
    cpu = time.process_time()
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(1)
    start = time.perf_counter()
    proc = subprocess.Popen([sys.executable, str(script), str(server.getsockname()[1])])
    conn, _ = server.accept()
    stream = conn.makefile("rwb")
    steps = 0
    for _ in range(episodes):
        done = False
        while not done:
            stream.write(b'{"finished":0,"enabledOperations":"Move_Right,Move_Down",'
                         b'"externalValues":{}}\n')
            stream.flush()
            answer = json.loads(stream.readline())
            done = answer["done"] == "true"
            steps += answer["op"] != "$initialise_machine"
    stream.write(b'{"finished":1,"enabledOperations":"","externalValues":{}}\n')
    stream.flush()
    conn.close()
    proc.wait()
    server.close()
    return time.perf_counter() - start, time.process_time() - cpu, steps


def with_tracecheck(script: Path, episodes: int, shield) -> tuple[float, float, int]:
    """tracecheck's side: (seconds, CPU seconds of this process, steps)."""
    settings = ExternalSettings(command=(sys.executable, str(script)), episodes=episodes)
    cpu = time.process_time()
    start = time.perf_counter()
    steps = sum(e.end.steps for e in external_episodes(settings, shield))
    return time.perf_counter() - start, time.process_time() - cpu, steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    shield = load_shield("frozenlake")
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / "walker.py"
        script.write_text(SCRIPT)
        with_tracecheck(script, 2, shield)  # warm: the grammar, the compiled guards
        base, ours, base_cpu, our_cpu = [], [], [], []
        for _ in range(args.repeat):
            t, c, n = baseline(script, args.episodes)
            base.append(t / n)
            base_cpu.append(c / n)
            t, c, m = with_tracecheck(script, args.episodes, shield)
            assert m == n, (m, n)
            ours.append(t / m)
            our_cpu.append(c / m)
    b, o = statistics.median(base), statistics.median(ours)
    bc, oc = statistics.median(base_cpu), statistics.median(our_cpu)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{args.episodes} episodes x {n // args.episodes} steps, medians of {args.repeat}:")
    print(f"  baseline (protocol only): {b * 1e6:8.0f} us per step")
    print(f"  tracecheck:               {o * 1e6:8.0f} us per step  ({o / b:.1f}x; "
          f"{(o - b) * 1e6:.0f} us of B per step)")
    print(f"  CPU time of this process (the side that answers the script; the script's own "
          f"is not in it): baseline {bc * 1e6:.0f} us per step, tracecheck {oc * 1e6:.0f} us "
          "per step")
    print(f"  peak memory of this process: {peak:.0f} MiB")


if __name__ == "__main__":
    main()
