"""Tables 2 and 3 of the paper next to ours (docs/reproduction.md).

    python benchmarks/reproduce_paper.py RUNS_DIR

RUNS_DIR holds the six recordings made by the commands in docs/reproduction.md:
{base,higher_penalty}_{none,paper,strict}.mcap. Prints Markdown.
"""

from __future__ import annotations

import sys
from pathlib import Path

from tracecheck.stats.estimates import statistics
from tracecheck.stats.properties import load_properties

HIGHWAY_SET = load_properties("highway")

# The paper's Tables 2 and 3 (BASE none, BASE shield, HIGHER PENALTY none, HP shield).
PAPER_METRICS = {
    "episode_length": ["38.85 ± 22.41", "56.71 ± 11.47", "53.02 ± 15.32", "59.16 ± 5.54"],
    "velocity": ["23.37 ± 2.17", "21.49 ± 0.94", "21.14 ± 0.79", "20.95 ± 0.63"],
    "distance": ["876.35 ± 477.62", "1213.30 ± 244.48", "1117.18 ± 321.71", "1238.04 ± 122.12"],
    "right_lane": ["31.69 ± 22.29", "42.26 ± 20.51", "47.07 ± 17.85", "48.73 ± 17.52"],
    "total_reward": ["30.41 ± 17.39", "42.88 ± 8.86", "39.90 ± 11.77", "44.20 ± 4.42"],
}
PAPER_SAF = {
    "SAF1": [45.4, 91.8, 78.5, 97.4], "SAF2": [93.4, 91.4, 76.9, 83.0],
    "SAF3": [95.2, 98.8, 100.0, 100.0], "SAF4": [100.0] * 4, "SAF5": [100.0] * 4,
    "SAF6": [6.4, 49.2, 41.6, 70.5],
}
RUNS = ["base_none", "base_paper", "higher_penalty_none", "higher_penalty_paper",
        "base_strict", "higher_penalty_strict"]


def main() -> None:
    folder = Path(sys.argv[1])
    paths = [folder / f"{r}.mcap" for r in RUNS if (folder / f"{r}.mcap").exists()]
    result = statistics(paths, HIGHWAY_SET)
    runs = {r["name"]: r for r in result["runs"]}
    head = ("| | BASE none | BASE paper | HP none | HP paper | BASE strict | HP strict |\n"
            "|---|---|---|---|---|---|---|")
    print("## Table 2: metrics (mean ± sd, 95 % t interval of the mean)\n")
    print(head)
    for name, paper in PAPER_METRICS.items():
        ours = []
        for r in RUNS:
            m = runs[r]["metrics"][name] if r in runs else None
            ours.append(f"{m['mean']:.2f} ± {m['sd']:.2f} [{m['ci95'][0]:.2f}, "
                        f"{m['ci95'][1]:.2f}]" if m else "–")
        print(f"| {name} (ours) | " + " | ".join(ours) + " |")
        print(f"| {name} (paper) | " + " | ".join(paper) + " | – | – |")
    print("\n## Table 3: properties (% of episodes, 95 % Wilson interval)\n")
    print(head)
    for name, paper in PAPER_SAF.items():
        ours = []
        for r in RUNS:
            p = runs[r]["properties"][name] if r in runs else None
            ours.append(f"{100 * p['ratio']:.1f} [{100 * p['ci95'][0]:.1f}, "
                        f"{100 * p['ci95'][1]:.1f}]" if p else "–")
        print(f"| {name} (ours) | " + " | ".join(ours) + " |")
        print(f"| {name} (paper) | " + " | ".join(f"{v:.1f}" for v in paper) + " | – | – |")
    print("\n## Paired comparisons (same seeds)\n")
    for c in result["comparisons"]:
        saf1 = c["properties"]["SAF1"]
        print(f"- {c['runs'][0]} vs {c['runs'][1]}: SAF1 holds only in the first in "
              f"{saf1['only_first']}, only in the second in {saf1['only_second']} of "
              f"{c['pairs']} paired episodes (exact McNemar p = {saf1['p_value']:.3g})")


if __name__ == "__main__":
    main()
