#!/usr/bin/env python3
"""frame_table.py: bench_frame's figures as docs/frame.md's table.

  bench/frame_table.py record BENCH.json OUT.json --machine TEXT   BENCH.json: bench_frame --json; OUT.json adds the
                                                                   commit, date and machine
  bench/frame_table.py table OUT.json DOC.md                       rewrite the part of DOC.md between
                                                                   "<!-- bench-frame begin -->" and "... end -->"

OUT.json is docs/results/bench-frame.json; `python3 scripts/results_tables.py` draws its table into
docs/results/frame.md with this script's table().
"""
import datetime
import json
import subprocess
import sys


def record(src, out, machine):
    d = json.load(open(src))
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            check=True).stdout.strip()
    d["recorded"] = {"commit": commit, "date": datetime.date.today().isoformat(), "machine": machine}
    with open(out, "w") as f:
        json.dump(d, f, indent=1)
        f.write("\n")


def table(src, doc):
    d = json.load(open(src))
    det, rec = d["detail"], d["recorded"]
    lines = [f'{det["width"]}x{det["height"]} `sun-shadow`, median of {d["runs"]} runs, at {rec["commit"]} '
             f'({rec["date"]}) on {rec["machine"]}; all threads = {det["scenes"][0]["threads_all"]} '
             '(`docs/results/bench-frame.json`, written into this table by `bench/frame_table.py`):', "",
             "| scene | primary / shadow rays | frame, all stages kept: all threads (1) | generate / trace / shade / "
             "resolve ms (all threads) | no stage kept | TRACE / Embree, all threads (1) | bundle, write time | "
             "peak RSS |",
             "|---|---|---|---|---|---|---|---|"]
    for s in det["scenes"]:
        a, o, g = s["all_threads"], s["one_thread"], s.get("golden")
        gold = (f'{g["bundle_mib"]:.0f} MiB, {g["write_s"]:.1f} s | {g["peak_rss_mib"]:.0f} MiB = '
                f'{g["peak_rss_mib"] / g["bundle_mib"]:.2f}x' if g else "- | -")
        lines.append(f'| {s["scene"]} | {s["primary_rays"]:,} / {s["shadow_rays"]:,} | {a["total_s"]:.2f} s '
                     f'({o["total_s"]:.2f} s) | {a["generate_ms"]:.0f} / {a["trace_ms"]:.0f} / {a["shade_ms"]:.0f} / '
                     f'{a["resolve_ms"]:.0f} | {a["no_stage_kept_s"]:.2f} s | {a["trace_over_embree"]:.2f}x '
                     f'({o["trace_over_embree"]:.2f}x) | {gold} |')
    text = open(doc).read()
    begin, end = "<!-- bench-frame begin -->", "<!-- bench-frame end -->"
    a, b = text.index(begin) + len(begin), text.index(end)
    open(doc, "w").write(text[:a] + "\n\n" + "\n".join(lines) + "\n\n" + text[b:])


if __name__ == "__main__":
    if len(sys.argv) == 6 and sys.argv[1] == "record" and sys.argv[4] == "--machine":
        record(sys.argv[2], sys.argv[3], sys.argv[5])
    elif len(sys.argv) == 4 and sys.argv[1] == "table":
        table(sys.argv[2], sys.argv[3])
    else:
        sys.exit(__doc__)
