#!/usr/bin/env python3
"""vbuffer_crosscheck.py: the rasterizer beside the tracer (rtoracle vbuffer --crosscheck) as a results table.

  tests/tools/vbuffer_crosscheck.py run RTORACLE OUT.json [--width W --height H]
      runs `RTORACLE vbuffer SCENE --msaa M --crosscheck` for every fixture, rtstress:8, sphere:3, triangle,
      random:1..8 and a camera inside rtstress:4, at 1x and 4x, and writes each run's crosscheck counts and the
      bundle's admissible-set statistics with the commit and date (the machine does not change the counts)
  tests/tools/vbuffer_crosscheck.py table OUT.json DOC.md
      rewrites the part of DOC.md between "<!-- vbuffer-crosscheck begin -->" and "<!-- vbuffer-crosscheck end -->"
"""
import datetime
import glob
import json
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
INSIDE = "0.1,0.2,0.3,5,1,2,0,1,0,90"
KEYS = ["agree", "tie", "clip_plane", "snap", "masked", "unexplained"]
PATTERN = (r"crosscheck: (\d+) samples: (\d+) agree with the tracer, (\d+) ties, (\d+) on the near or far plane, "
           r"(\d+) within snapping of an edge, (\d+) on a masked instance, (\d+) unexplained")


def scenes():
    fix = sorted(glob.glob(os.path.join(ROOT, "fixtures", "*", "glTF", "*.gltf")) +
                 glob.glob(os.path.join(ROOT, "fixtures", "*", "*.gltf")))
    out = [(os.path.relpath(f, ROOT), os.path.relpath(f, ROOT), None) for f in fix if "/golden" not in f]
    out += [(s, s, None) for s in ["rtstress:8", "sphere:3", "triangle"] + [f"random:{k}" for k in range(1, 9)]]
    out.append(("rtstress:4, camera inside", "rtstress:4", INSIDE))
    return out


def run(rto, out, width, height):
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, spec, camera in scenes():
            for msaa in (1, 4):
                cmd = [rto, "vbuffer", spec, "--width", str(width), "--height", str(height), "--msaa", str(msaa),
                       "--crosscheck", "-o", os.path.join(tmp, "b")]
                if camera:
                    cmd += ["--camera", camera]
                p = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
                m = re.search(PATTERN, p.stdout)
                if not m or p.returncode not in (0, 1):
                    sys.exit(f"vbuffer_crosscheck: {' '.join(cmd)}: {p.stdout}{p.stderr}")
                with open(os.path.join(tmp, "b", "manifest.json")) as f:
                    adm = json.load(f)["admissible"]
                row = {"scene": name, "msaa": msaa, "samples": int(m.group(1))}
                row.update({k: int(v) for k, v in zip(KEYS, m.groups()[1:])})
                row["admissible"] = adm
                rows.append(row)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                            check=True).stdout.strip()
    with open(out, "w") as f:
        json.dump({"commit": commit, "date": datetime.date.today().isoformat(), "width": width, "height": height,
                   "rows": rows}, f, indent=1)
        f.write("\n")


def table(src, doc):
    d = json.load(open(src))
    lines = ["<!-- vbuffer-crosscheck begin -->", "",
             f"`rtoracle vbuffer SCENE --width {d['width']} --height {d['height']} --msaa M --crosscheck` at commit "
             f"{d['commit']} ({d['date']}; `{os.path.relpath(src, ROOT) if os.path.isabs(src) else src}`). "
             "Samples: the rays traced, one per sample; agree: the tracer's closest hit is in the admissible set; "
             "the other columns are the explanations of docs/vbuffer.md; sets of 2, 3, 4+: uncertain samples by the "
             "size of their admissible set.", "",
             "| scene | MSAA | samples | agree | tie | near/far | snapping | masked | unexplained | covered | "
             "sets of 2 | 3 | 4+ | largest |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in d["rows"]:
        a = r["admissible"]
        lines.append(f"| `{r['scene']}` | {r['msaa']}× | {r['samples']} | {r['agree']} | {r['tie']} | "
                     f"{r['clip_plane']} | {r['snap']} | {r['masked']} | **{r['unexplained']}** | {a['covered']} | "
                     f"{a['sets_of_2']} | {a['sets_of_3']} | {a['sets_of_4'] + a['sets_of_5_or_more']} | "
                     f"{a['max_set']} |")
    lines += ["", "<!-- vbuffer-crosscheck end -->"]
    text = open(doc).read()
    begin, end = text.index("<!-- vbuffer-crosscheck begin -->"), text.index("<!-- vbuffer-crosscheck end -->")
    text = text[:begin] + "\n".join(lines) + text[end + len("<!-- vbuffer-crosscheck end -->"):]
    open(doc, "w").write(text)


if __name__ == "__main__":
    a = sys.argv[1:]
    if len(a) >= 3 and a[0] == "run":
        w = int(a[a.index("--width") + 1]) if "--width" in a else 160
        h = int(a[a.index("--height") + 1]) if "--height" in a else 120
        run(os.path.abspath(a[1]), os.path.abspath(a[2]), w, h)
    elif len(a) == 3 and a[0] == "table":
        table(a[1], a[2])
    else:
        sys.exit(__doc__)
