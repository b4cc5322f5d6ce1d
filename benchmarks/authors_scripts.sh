#!/usr/bin/env bash
# The paper authors' own glue scripts, unchanged, under `tracecheck record --external`, each
# with its machine as the shield, then replayed: every recorded step must be feasible.
#
#   benchmarks/authors_scripts.sh AUTHORS_CHECKOUT [VENV] [EPISODES]
#
# AUTHORS_CHECKOUT is a checkout of hhu-stups/reinforcement-learning-b-models (its trained
# agents included); VENV the Python environment the scripts need, made here with their
# pinned packages when it does not exist (gymnasium 0.28.1, highway-env 1.8.2,
# stable-baselines3 2.0.0, the old gym for the drone swarm); tracecheck itself is the one
# on PATH (or $TRACECHECK). Where a checkout lacks a trained agent (the binary files),
# STAND_INS=1 saves an untrained one of the same architecture at its path first: then the
# protocol and the machines are what is checked, not the agents' skill. Prints a line per
# script and exits 1 if a run failed or a recorded step was not feasible.
set -u
repo=$(cd "${1:?usage: authors_scripts.sh AUTHORS_CHECKOUT [VENV] [EPISODES]}" && pwd)
venv=${2:-$repo/.venv-authors}
episodes=${3:-5}
tc=${TRACECHECK:-tracecheck}
out=$(mktemp -d)
py=$venv/bin/python

if [ ! -x "$py" ]; then
  python3.11 -m venv "$venv" && "$venv/bin/pip" install -q torch==2.13.0 gymnasium==0.28.1 \
    highway-env==1.8.2 stable-baselines3==2.0.0 gym==0.26.2 joblib==1.3.1 numpy==1.25.0 \
    pandas==2.0.3 matplotlib==3.7.2 seaborn || exit 2
fi

if [ "${STAND_INS:-0}" = 1 ]; then
  (cd "$repo" && "$py" - 2>"$out/stand-ins.log" <<'EOF'
import os, runpy
import gymnasium as gym
from stable_baselines3 import DQN

def standin(env, path):
    if not os.path.exists(path + ".zip"):
        os.makedirs(os.path.dirname(path), exist_ok=True)
        DQN("MlpPolicy", env, policy_kwargs=dict(net_arch=[256, 256]), seed=0).save(path)
        print("stand-in", path + ".zip")

standin(gym.make("FrozenLake-v1", map_name="8x8", is_slippery=False),
        "FrozenLake/models/new/trained_model")
standin(gym.make("CliffWalking-v0"), "CliffWalking/models/new/trained_model")
import highway_env  # noqa: F401  (registers highway-fast-v0)
for name in ("base", "higher_col_penalty"):
    standin(gym.make("highway-fast-v0"),
            f"HighwayEnvironment/models/highway_dqn/{name}/trained_model")
os.chdir("AutonomousDroneSwarm")
if not os.path.exists("q_class_multi_fixed_small_fov.txt"):
    import __main__, joblib, numpy as np
    ns = runpy.run_path("MultiAgent2_small.py", run_name="authors")
    for key, obj in ns.items():  # pickled as the unchanged script will look them up
        if isinstance(obj, type) and obj.__module__ == "authors":
            obj.__module__ = "__main__"
            setattr(__main__, key, obj)
    np.random.seed(0)
    grid = ns["Grid"](x_size=4, y_size=4, n_agents=2)
    joblib.dump([ns["QTables"](grid.observation_space, grid.action_space)],
                "q_class_multi_fixed_small_fov.txt", compress=3)
    print("stand-in AutonomousDroneSwarm/q_class_multi_fixed_small_fov.txt")
EOF
  ) || exit 2
fi

failed=0
run() {  # FOLDER SCRIPT MACHINE
  local dir=$repo/$1 script=$2 machine=$repo/$1/$3 name=${2%.py} start
  start=$(date +%s.%N)
  if ! (cd "$dir" && "$tc" record --external "$py $script" --shield "$machine" \
          --episodes "$episodes" --ending-time 60000 -o "$out/$name.mcap" >"$out/$name.log" 2>&1); then
    echo "$name: FAILED"; sed 's/^/    /' "$out/$name.log"; failed=1; return
  fi
  local took report
  took=$(echo "$(date +%s.%N) - $start" | bc)
  report=$("$tc" replay "$out/$name.mcap" --shield "$machine" --format json)
  echo "$report" | "$py" -c '
import json, sys
r = json.load(sys.stdin)
keys = ("infeasible_steps", "postcondition_violations", "invariant_violations")
bad = sum(r[k] for k in keys)
print("%s: %d episodes, %d steps in %.1f s; infeasible %d, postcondition %d, invariant %d"
      % (sys.argv[1], r["episodes"], r["steps"], float(sys.argv[2]), *(r[k] for k in keys)))
sys.exit(1 if bad else 0)' "$name" "$took" || failed=1
  if pgrep -f "$script" >/dev/null; then echo "    a $script process was left behind"; failed=1; fi
}
run FrozenLake FrozenLake.py FrozenLake.mch
run CliffWalking CliffWalking.py CliffWalking.mch
run HighwayEnvironment HighwayEnvironment.py HighwayEnvironment2.mch
run HighwayEnvironment HighwayEnvironment_Base.py HighwayEnvironment.mch
run AutonomousDroneSwarm MultiAgent2_small.py AutonomousDroneSwarm_small_abstract.mch
echo "runs and logs: $out"
exit $failed
