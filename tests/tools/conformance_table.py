#!/usr/bin/env python3
"""conformance_table.py: the simulated-GPU family of unit.conformance as a results table.

  tests/tools/conformance_table.py record CASES.jsonl OUT.json   CASES.jsonl: what test_conformance appends with
                                                                 RTO_CONFORMANCE_JSON=FILE (one object per scene
                                                                 and ray class); OUT.json adds the commit and date
  tests/tools/conformance_table.py table OUT.json DOC.md         rewrite the section of DOC.md between
                                                                 "<!-- conformance-family begin -->" and "... end -->"
"""
import datetime
import json
import subprocess
import sys

CLASSES = ["primary", "shadow", "random", "grazing", "axis", "vertex/edge/surface/range"]


def record(cases, out):
    rows = [json.loads(line) for line in open(cases) if line.strip()]
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            check=True).stdout.strip()
    with open(out, "w") as f:
        json.dump({"commit": commit, "date": datetime.date.today().isoformat(), "cases": rows}, f, indent=1)
        f.write("\n")


def table(src, doc):
    d = json.load(open(src))
    scenes = []
    for c in d["cases"]:
        if c["scene"] not in scenes:
            scenes.append(c["scene"])
    lines = ["| scene | GPUs | " + " | ".join(CLASSES) + " | records | not the oracle's bits | rejected |",
             "|---|---:|" + "---:|" * len(CLASSES) + "---:|---:|---:|"]
    tot = {"records": 0, "differing": 0, "rejected": 0, "rays": 0}
    for s in scenes:
        cs = {c["rays"]: c for c in d["cases"] if c["scene"] == s}
        cells = []
        for k in CLASSES:
            c = cs.get(k)
            cells.append(f'{c["count"]:,} ({c["hits"]:,} hits)' if c else "-")
        rec = sum(c["records"] for c in cs.values())
        dif = sum(c["differing"] for c in cs.values())
        rej = sum(c["rejected"] for c in cs.values())
        gpus = max(c["gpus"] for c in cs.values())
        tot["records"] += rec
        tot["differing"] += dif
        tot["rejected"] += rej
        tot["rays"] += sum(c["count"] for c in cs.values())
        lines.append(f"| `{s}` | {gpus} | " + " | ".join(cells) + f" | {rec:,} | {dif:,} | {rej} |")
    lines.append("")
    lines.append(f'Total: {tot["rays"]:,} rays, {tot["records"]:,} records checked, {tot["differing"]:,} of them not '
                 f'the oracle\'s bit for bit, {tot["rejected"]} rejected (unit.conformance at {d["commit"]}, '
                 f'{d["date"]}; `tests/tools/conformance_table.py` writes this table from '
                 f'`docs/results/conformance-family.json`).')
    text = open(doc).read()
    begin, end = "<!-- conformance-family begin -->", "<!-- conformance-family end -->"
    a, b = text.index(begin) + len(begin), text.index(end)
    open(doc, "w").write(text[:a] + "\n\n" + "\n".join(lines) + "\n\n" + text[b:])


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "record":
        record(sys.argv[2], sys.argv[3])
    elif len(sys.argv) == 4 and sys.argv[1] == "table":
        table(sys.argv[2], sys.argv[3])
    else:
        sys.exit(__doc__)
