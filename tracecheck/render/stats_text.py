"""Statistics for people: tables side by side like the paper's Tables 2 and 3, CSV, plots."""

from __future__ import annotations

import math

from contextlib import contextmanager
from pathlib import Path
from typing import Any, Iterator

from rich.console import Console
from rich.table import Table
from rich.text import Text

from .emit import Report
from .tables import TableData

__all__ = ["StatsOutput", "stats_plots", "check_plot_folder",
           "plain_plot_text", "stats_svgs", "stats_rows"]

#: What ``stats --plot`` writes into its folder (``--force`` replaces only such a folder).
PLOT_FILES = ("*.png", "*.svg")


def _metric_cell(m: dict, lines: bool = False) -> str:
    """Mean ± sd and its interval; ``lines``: the interval on a line of its own (a terminal
    table then wraps between the parts, never inside one)."""
    if "mean_note" in m and not math.isfinite(m["mean"]):  # the text says why below
        return "— (not finite)"
    if m["sd"] is None:
        text = f"{m['mean']:.2f}"
    else:
        lo, hi = m["ci95"]
        text = f"{m['mean']:.2f} ± {m['sd']:.2f}{_SEP[lines]}[{lo:.2f}, {hi:.2f}]"
    e = m.get("estimate")
    if e is not None:  # SimB's estimation check: the mean within value ± epsilon
        text += f"{chr(10) if lines else '; '}estimate {e['value']:g} ± {e['epsilon']:g} " \
                f"({e['type']}): {'within' if e['within'] else 'not within'}"
    return text


def _property_cell(p: dict, lines: bool = False) -> str:
    """Share and interval (then the test's verdict and p-value, after "; "); ``lines``: each
    part on a line of its own."""
    lo, hi = p["ci95"]
    text = f"{100 * p['ratio']:.1f} %{_SEP[lines]}[{100 * lo:.1f}, {100 * hi:.1f}]"
    if "test" in p:
        t = p["test"]
        verdict = "rejected" if t["exact_rejected"] else "not rejected"
        then = "\n" if lines else "; "
        text += f"{then}H0 {verdict}{_SEP[lines]}(p={t['exact_p_value']:.3g})"
    return text


_SEP = {False: " ", True: "\n"}  # between the parts of a cell: on one line, or one per line


def stats_rows(result: dict, lines: bool = False) -> tuple[list[str], list[list[str]]]:
    """Header and rows; ``lines``: cells split into lines for a terminal."""
    runs = result["runs"]
    header = ["", *[f"{r['name']}{_SEP[lines]}({r['episodes']} ep.)" for r in runs]]
    rows = []
    first = next((r for r in runs if r["episodes"]), None)
    if first is None:
        return header, [["(no episodes in any run)", *["" for _ in runs]]]
    for name in first["metrics"]:
        label = result["descriptions"].get(name) or name
        rows.append([label, *[_metric_cell(r["metrics"][name], lines) if r["episodes"] else
                              "no episodes" for r in runs]])
    for name in first["properties"]:
        label = f"{name}: {result['descriptions'].get(name) or ''}".rstrip(": ")
        rows.append([label, *[_property_cell(r["properties"][name], lines) if r["episodes"]
                              else "no episodes" for r in runs]])
    return header, rows + _continuous_rows(runs, lines)


#: the continuous actions' step statistics (:mod:`tracecheck.stats.continuous`): label, key
_STEP_SHARES = (("Intervention rate (share of steps)", "interventions"),
                ("On the allowed set's boundary (share of steps)", "boundary"),
                ("Fallback taken (share of steps)", "fallback"))
_CSV_NAMES = {"interventions": "intervention_rate", "boundary": "boundary_share",
              "fallback": "fallback_share"}
_DISTANCES = (("Projection distance (all steps)", None),
              ("Projection distance (intervened steps)", "intervened"))


def _continuous_rows(runs: list[dict], lines: bool) -> list[list[str]]:
    """Rows for the runs with continuous actions (none when no run has them: a discrete
    run's table is as it was); a run without them says so in its cell."""
    if not any("continuous" in r for r in runs):
        return []
    rows = []
    for label, key in _STEP_SHARES:
        rows.append([label, *[_share_cell(r["continuous"][key], lines) if "continuous" in r
                              else "—" for r in runs]])
    for label, key in _DISTANCES:
        rows.append([label, *[_distance_cell(r["continuous"]["projection_distance"], key,
                                             lines) if "continuous" in r else "—"
                              for r in runs]])
    return rows


def _share_cell(share: dict, lines: bool) -> str:
    """A share of steps, its interval and count: ``12.5 % [8.1, 18.2] (20 of 160)``."""
    if share["ratio"] is None:
        return "no steps"
    lo, hi = share["ci95"]
    return (f"{100 * share['ratio']:.1f} %{_SEP[lines]}[{100 * lo:.1f}, {100 * hi:.1f}]"
            f"{_SEP[lines]}({share['count']} of {share['steps']})")


def _distance_cell(distance: dict, key, lines: bool) -> str:
    """Mean and largest projection distance: ``mean 1.23, max 6.00``."""
    d = distance[key] if key else distance
    if d["mean"] is None:
        return "no steps"
    return f"mean {d['mean']:.3g},{_SEP[lines]}max {d['max']:.3g}"


def _stats_text(console: Console, result: dict) -> None:
    from .text import literal_row

    header, rows = stats_rows(result, lines=True)
    title = (f"{result['properties_set']}: metrics mean ± sd [95 % t interval]; "
             f"properties % of episodes [95 % {result['interval']} interval]")
    groups = _run_groups(header, rows, console.width)
    for n, group in enumerate(groups):  # runs side by side as far as the width takes them,
        #                                 each table with the labels (numbers never nameless)
        table = Table(title=Text(title if len(groups) == 1 else
                                 f"{title} ({n + 1} of {len(groups)}: runs "
                                 f"{', '.join(str(header[i]).split(chr(10))[0] for i in group)})"),
                      show_lines=True)
        table.add_column(Text(header[0]), min_width=min(_LABEL_WIDTH, _widest([r[0] for r in rows])),
                         overflow="fold")
        for i in group:  # a value column keeps each item on a line of its own
            table.add_column(Text(header[i]), no_wrap=True)
        for row in rows:
            literal_row(table, [row[0], *(row[i] for i in group)])
        console.print(table, soft_wrap=False)
    if any("continuous" in r for r in result["runs"]):
        console.print(Text("Shares of steps treat the steps as independent trials; the "
                           "boundary is the shield's, not the action space's own bounds "
                           "(docs/statistics.md)."))
    for r in result["runs"]:  # why a cell has no number
        for name, m in r["metrics"].items():
            if "mean_note" in m and not math.isfinite(m["mean"]):
                label = result["descriptions"].get(name) or name
                console.print(Text(f"{label}, {r['name']}: {m['mean_note']}"))
    for c in result["comparisons"]:
        console.print(f"paired {c['runs'][0]} vs {c['runs'][1]} ({c['pairs']} shared seeds):",
                      highlight=False)
        for name, p in c["properties"].items():
            console.print(f"  {name}: only {c['runs'][0]} {p['only_first']}, only "
                          f"{c['runs'][1]} {p['only_second']} (exact McNemar p="
                          f"{p['p_value']:.3g})", highlight=False, soft_wrap=False)
        for name, m in c["metrics"].items():
            t = "n/a" if m["paired_t_p"] is None else f"{m['paired_t_p']:.3g}"
            w = "n/a" if m["wilcoxon_p"] is None else f"{m['wilcoxon_p']:.3g}"
            console.print(f"  {name}: mean difference {m['mean_difference']:.3f} (paired t "
                          f"p={t}, Wilcoxon p={w})", highlight=False, soft_wrap=False)


#: the width the row labels keep however many runs share the line
_LABEL_WIDTH = 22


def _widest(cells) -> int:
    return max((len(line) for cell in cells for line in str(cell).split("\n")), default=0)


def _run_groups(header: list, rows: list, width: int) -> list[list[int]]:
    """The run columns (indices into ``header``) in groups that fit ``width`` beside the
    labels: all in one where they fit; at least one run per group."""
    groups: list[list[int]] = [[]]
    used = _LABEL_WIDTH + 4  # the label column and the table's outer borders
    for i in range(1, len(header)):
        need = _widest([header[i], *(r[i] for r in rows)]) + 3
        if groups[-1] and used + need > width:
            groups.append([])
            used = _LABEL_WIDTH + 4
        groups[-1].append(i)
        used += need
    return groups


def _stats_markdown(result: dict) -> str:
    from .tables import markdown

    return markdown(TableData.of(*stats_rows(result)))


def _stats_csv(result: dict) -> str:
    """One row per run and metric or property; numbers stay numbers, text is made inert
    (:func:`~tracecheck.render.tables.csv_cell`)."""
    from .tables import csv_rows

    rows = [["run", "file", "episodes", "name", "kind", "value", "sd", "ci95_low",
             "ci95_high", "holds", "method"]]
    for r in result["runs"]:
        if not r["episodes"]:
            rows.append([r["name"], r["file"], 0, "", "", "", "", "", "", "", "no episodes"])
        for name, m in r["metrics"].items():
            lo, hi = m["ci95"] or ("", "")
            rows.append([r["name"], r["file"], r["episodes"], name, "metric", m["mean"],
                         m["sd"] if m["sd"] is not None else "", lo, hi, "", m["method"]])
        for name, p in r["properties"].items():
            rows.append([r["name"], r["file"], r["episodes"], name, "property", p["ratio"], "",
                         p["ci95"][0], p["ci95"][1], p["holds"], p["method"]])
        rows += _continuous_csv(r)
    return csv_rows(rows)


def _continuous_csv(r: dict) -> list[list]:
    """The CSV rows of a run's continuous actions (none for a discrete run): the shares of
    steps (``holds``: how many steps), the projection distances (``method``: mean, max)."""
    c = r.get("continuous")
    if c is None:
        return []
    rows = []
    for _, key in _STEP_SHARES:
        share = c[key]
        lo, hi = share["ci95"] or ("", "")
        rows.append([r["name"], r["file"], r["episodes"], _CSV_NAMES[key], "step share",
                     "" if share["ratio"] is None else share["ratio"], "", lo, hi,
                     share["count"], share["method"]])
    for _, key in _DISTANCES:
        d = c["projection_distance"][key] if key else c["projection_distance"]
        name = "projection_distance" + (f"_{key}" if key else "")
        for how in ("mean", "max"):
            rows.append([r["name"], r["file"], r["episodes"], name, "step metric",
                         "" if d[how] is None else d[how], "", "", "", d["steps"], how])
    return rows


@contextmanager
def plain_plot_text():
    """matplotlib shows every string as the text it is: no TeX (``text.usetex`` off) and no
    mathtext (``text.parse_math`` off, the same as escaping every ``$``), so a description,
    a property or a file name with ``$\\frac{1}$`` in it is drawn, not parsed (and cannot
    crash the plot). Every plot is drawn inside this; usable as a decorator."""
    import matplotlib

    with matplotlib.rc_context({"text.usetex": False, "text.parse_math": False}):
        yield


def check_plot_folder(folder: Path, inputs=(), force: bool = False) -> Path:
    """The output rule (:mod:`tracecheck.outputs`) for a folder of plots."""
    from ..outputs import check_output

    return check_output(folder, inputs, force=force, kind="folder", what="--plot folder",
                        contents=PLOT_FILES)


@plain_plot_text()
def stats_plots(result: dict, folder: Path, *, force: bool = False) -> list[Path]:
    """PNG and SVG: property shares with intervals per run; metric distributions per run.

    The folder follows the output rule: written beside it and renamed into place when every
    plot is drawn; an existing folder of plots is replaced only with ``force``; a metric's
    file name is its name made safe (``metric_x_._._escaped.png`` for ``x/../../escaped``).
    """
    from ..outputs import atomic_folder

    folder = check_plot_folder(Path(folder), force=force)
    with atomic_folder(folder) as tmp:
        written = [path for stem, fig in _figures(result) for path in _save(fig, tmp, stem)]
    return [folder / p.name for p in written]


@plain_plot_text()
def stats_svgs(result: dict) -> list[str]:
    """The plots of :func:`stats_plots` as inline SVG texts (the report's), in its order."""
    import io

    import matplotlib.pyplot as plt

    svgs = []
    for _, fig in _figures(result):
        fig.tight_layout()
        buf = io.StringIO()
        fig.savefig(buf, format="svg")
        plt.close(fig)
        text = buf.getvalue()
        svgs.append(text[text.index("<svg"):])
    return svgs


def _figures(result: dict) -> Iterator[tuple[str, Any]]:
    """(file stem, figure) for each plot: property shares, then one per metric."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from ..outputs import safe_name

    runs = [r for r in result["runs"] if r["episodes"]]
    values = {v.name: v for v in result.values}
    if not runs:
        return
    props = list(runs[0]["properties"])
    if props:
        fig, ax = plt.subplots(figsize=(max(6, 1.2 * len(props) * len(runs)), 4))
        width = 0.8 / len(runs)
        for i, r in enumerate(runs):
            ratios = [100 * r["properties"][p]["ratio"] for p in props]
            lo = [ratios[j] - 100 * r["properties"][p]["ci95"][0] for j, p in enumerate(props)]
            hi = [100 * r["properties"][p]["ci95"][1] - ratios[j] for j, p in enumerate(props)]
            ax.bar(np.arange(len(props)) + i * width, ratios, width, yerr=[lo, hi],
                   capsize=3, label=r["name"])
        ax.set_xticks(np.arange(len(props)) + width * (len(runs) - 1) / 2, props)
        ax.set_ylabel(f"% of episodes (95 % {result['interval']} interval)")
        ax.set_ylim(0, 105)
        # above the plot, in a row: inside, a share of 100 % has no free corner to take
        ax.legend(loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=len(runs),
                  frameon=False)
        yield "properties", fig
    taken = {"properties"}
    for name in runs[0]["metrics"]:
        fig, ax = plt.subplots(figsize=(max(5, 1.5 * len(runs)), 4))
        ax.boxplot([values[r["name"]].metrics[name] for r in runs])
        ax.set_xticks(range(1, len(runs) + 1), [r["name"] for r in runs])
        ax.set_title(result["descriptions"].get(name) or name)
        yield safe_name(f"metric_{name}", taken), fig


def _save(fig, folder: Path, stem: str) -> list[Path]:
    """``fig`` as ``STEM.png`` and ``STEM.svg`` in ``folder``, each a file created anew
    (never through a link)."""
    import matplotlib.pyplot as plt

    from ..outputs import inside, open_new

    fig.tight_layout()
    paths = []
    for fmt in ("png", "svg"):
        path = inside(folder, f"{stem}.{fmt}")
        with open_new(path) as stream:
            fig.savefig(stream, format=fmt)
        paths.append(path)
    plt.close(fig)
    return paths


class StatsOutput(Report):
    """``stats``'s and ``simulate``'s statistics in every format."""

    def __init__(self, result: dict) -> None:
        self.result = result

    def data(self):
        return self.result

    def table(self) -> TableData:
        header, rows = stats_rows(self.result)
        return TableData.of(header, rows)

    def markdown(self) -> str:
        return _stats_markdown(self.result)

    def csv(self) -> str:
        return _stats_csv(self.result)

    def text(self, console) -> None:
        _stats_text(console, self.result)
