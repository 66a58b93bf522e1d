"""Draws the ratios of rtoracle's benchmarks (their --json documents) as one PNG chart: a horizontal bar per
compared figure, time(oracle) / time(reference) on a log scale, a line at 1 (left of it the oracle is faster).

    python3 scripts/bench_plot.py -o chart.png sort.json bvh.json trace.json frame.json
"""
import argparse
import json
import sys

import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")  # no display: write the file only
import matplotlib.pyplot as plt  # noqa: E402


def fail(text):
    """One line on stderr, exit status 2 (bad input or usage)."""
    print(f"bench-plot: {text}", file=sys.stderr)
    sys.exit(2)


def rows_of(path):
    """The benchmark's name and its rows; exits with one line (status 2) on a file that is not a --json document."""
    try:
        with open(path, encoding="utf-8") as f:
            doc = json.load(f)
        return doc["benchmark"], doc["runs"], [r for r in doc["rows"] if r["ratio"] > 0]
    except (OSError, ValueError, KeyError, TypeError) as e:
        fail(f"{path}: not a benchmark --json document (missing or bad {e})")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", default="bench-ratios.png")
    ap.add_argument("files", nargs="+")
    args = ap.parse_args()
    labels, ratios, colours, runs = [], [], [], set()
    palette = plt.get_cmap("tab10")
    for k, path in enumerate(args.files):
        name, n, rows = rows_of(path)
        runs.add(n)
        for r in rows:
            threads = "1 thread" if r["threads"] == 1 else "all threads"
            labels.append(f"{name}: {r['case']}, {threads}, vs {r['reference']}")
            ratios.append(r["ratio"])
            colours.append(palette(k % 10))
    if not ratios:
        fail("the documents hold no rows")
    fig, ax = plt.subplots(figsize=(11, 0.28 * len(ratios) + 1.6))
    y = range(len(ratios))
    ax.barh(y, ratios, color=colours, left=0)
    ax.set_xscale("log")
    lo, hi = min(ratios + [1.0]) / 1.5, max(ratios + [1.0]) * 1.5
    ticks = [t for t in (0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1, 2, 5, 10, 20, 50, 100) if lo <= t <= hi]
    ax.set_xlim(lo, hi)
    ax.set_xticks(ticks)
    ax.set_xticklabels([f"{t:g}" for t in ticks])
    ax.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
    ax.axvline(1.0, color="black", linewidth=1)
    ax.set_yticks(list(y))
    ax.set_yticklabels(labels, fontsize=7)
    ax.invert_yaxis()
    for i, v in enumerate(ratios):
        ax.text(v, i, f" {v:.2f}", va="center", fontsize=7)
    ax.set_xlabel("time(oracle) / time(reference), median of %s runs (< 1: the oracle is faster)"
                  % "/".join(str(n) for n in sorted(runs)))
    ax.set_title("rtoracle against qsort and Embree on the same work in the same process")
    fig.tight_layout()
    fig.savefig(args.output, dpi=110)
    print(f"bench-plot: {len(ratios)} ratios drawn in {args.output}")


if __name__ == "__main__":
    main()
