#!/usr/bin/env python3
"""results.py: keep a GPU run's results and the tables docs/results/gpu.md shows from them (scripts/results_tables.py
  regenerates that file from every recorded run; the commands below rewrite one marked part of a doc).

  gpu/results.py record RUN.json OUT.json --commit C --date D --device TEXT --note TEXT
      OUT.json: gpu/run's --json output with where and when it ran (commit, date, device, how it was run), the
      case directories' paths left out.
  gpu/results.py table OUT.json [OUT2.json ...] --doc docs/results/gpu.md
      rewrites the part of the doc between "<!-- gpu-results begin -->" and "<!-- gpu-results end -->": one line
      per run (commit, date, device, driver, how), then one row per case (family, case, passes, what the check
      said besides pass, GPU time per run). Never typed by hand: run this again whenever a verdict rule changes.
  gpu/results.py sort-timings CI.json FULL.json --commit C --date D --doc docs/results/gpu.md
      rewrites the part between "<!-- sort-timings begin -->" and "<!-- sort-timings end -->": the sort families'
      cases and wall seconds in a --subset ci run and a full run (gpu/run --json of each).
"""
import argparse
import json
import sys

BEGIN = "<!-- gpu-results begin -->"
END = "<!-- gpu-results end -->"


def record(args):
    with open(args.run) as f:
        run = json.load(f)
    for r in run.get("results", []):
        r.pop("dir", None)
        r.pop("images", None)
    run["recorded"] = {"commit": args.commit, "date": args.date, "device": args.device, "note": args.note}
    with open(args.out, "w") as f:
        json.dump(run, f, indent=1, sort_keys=True)
        f.write("\n")


def gpu_time(r):
    ms = r.get("gpu_ms") or {}
    parts = []
    for stage, v in ms.items():
        runs = max(1, r.get("repeat", 1))
        parts.append(f"{stage} {v['ms'] / runs:.3f}")
    return ", ".join(parts) + " ms" if parts else "-"


def table(args):
    lines = [BEGIN, ""]
    for path in args.runs:
        with open(path) as f:
            run = json.load(f)
        rec = run["recorded"]
        results = run["results"]
        passed = sum(1 for r in results if r["pass"] and r["passes"] == r["repeat"])
        repeat = max([run["repeat"]] + [r["repeat"] for r in results])  # --check-only: the runs dumped
        lines.append(f"Run of commit {rec['commit']}, {rec['date']}, {rec['device']} ({run['adapter']}), "
                     f"{run['backend']}, `--repeat {repeat}`; {rec['note']}: **{passed} of {len(results)} "
                     f"cases pass every run** (`{path}`).")
        lines.append("")
        lines.append("| case | passes | check says | GPU time per run |")
        lines.append("|---|---|---|---|")
        for r in results:
            said = r.get("diagnosis") or r.get("fault") or ""
            said = "-" if said in ("", "none") else said.replace("|", "\\|")
            lines.append(f"| `{r['case']}` | {r['passes']}/{r['repeat']} | {said} | {gpu_time(r)} |")
        lines.append("")
    lines.append(END)
    rewrite(args.doc, BEGIN, END, lines)


def rewrite(path, begin, end, lines):
    """Replaces the part of the doc between the markers (both kept: lines starts and ends with them)."""
    with open(path) as f:
        doc = f.read()
    if begin not in doc or end not in doc:
        sys.exit(f"results.py: {path} has no {begin} ... {end} section")
    head, rest = doc.split(begin, 1)
    _, tail = rest.split(end, 1)
    with open(path, "w") as f:
        f.write(head + "\n".join(lines) + tail)


def sort_timings(args):
    """The sort families' wall time on a device, from a --subset ci run's JSON and a full run's: cases and seconds per
    family (the sum of the cases' wall_s, rtoracle's processes included)."""
    runs = [json.load(open(args.ci)), json.load(open(args.full))]
    begin, end = "<!-- sort-timings begin -->", "<!-- sort-timings end -->"
    lines = [begin, "", f"Commit {args.commit}, {args.date}, {runs[0]['adapter']} ({runs[0]['backend']}); every case "
             f"passing: {all(r['pass'] for run in runs for r in run['results'])} (`gpu/results.py sort-timings` from "
             f"`{args.ci}` and `{args.full}`):",
             "", "| family | `--subset ci` | full matrix |", "|---|---|---|"]
    fams = [f for f in runs[1]["families"]]
    cell = lambda run, fam: (lambda rs: f"{len(rs)} cases, {sum(r['wall_s'] for r in rs):.0f} s")(
        [r for r in run["results"] if fam is None or r["family"] == fam])
    for fam in fams:
        lines.append(f"| `{fam}` | {cell(runs[0], fam)} | {cell(runs[1], fam)} |")
    lines.append(f"| all three | {cell(runs[0], None)} | {cell(runs[1], None)} |")
    lines += ["", end]
    rewrite(args.doc, begin, end, lines)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("record")
    r.add_argument("run")
    r.add_argument("out")
    r.add_argument("--commit", required=True)
    r.add_argument("--date", required=True)
    r.add_argument("--device", required=True)
    r.add_argument("--note", required=True)
    t = sub.add_parser("table")
    t.add_argument("runs", nargs="+")
    t.add_argument("--doc", required=True)
    st = sub.add_parser("sort-timings")
    st.add_argument("ci")
    st.add_argument("full")
    st.add_argument("--commit", required=True)
    st.add_argument("--date", required=True)
    st.add_argument("--doc", required=True)
    args = p.parse_args()
    {"record": record, "table": table, "sort-timings": sort_timings}[args.cmd](args)


if __name__ == "__main__":
    main()
