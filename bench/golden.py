#!/usr/bin/env python3
"""The frame golden as a user makes it: `rtoracle render SCENE --program sun-shadow --width 1920 --height 1080 -o DIR`
(the lean golden, render's default stages) timed as a whole command (process start, glTF load, trees, frame, bundle
write), against the goals of 2 s wall and 50 MB on disk. Median of RUNS runs (default 7) with all threads; the
bundle's bytes and files; the peak RSS of one run (its own child). The full dump (--stages all) runs once beside it
for scale. Every run passes --force into the same directory (a fresh temporary one).

  python3 bench/golden.py RTORACLE SCENE [--runs N] [--json FILE]
"""
import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

GOAL_S, GOAL_MB = 2.0, 50.0


def render(rto, scene, out, stages=None):
    cmd = [rto, "render", scene, "--program", "sun-shadow", "--width", "1920", "--height", "1080", "--force",
           "-o", out]
    if stages:
        cmd += ["--stages", stages]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


def size_of(d):
    files = [os.path.join(d, f) for f in os.listdir(d)]
    return sum(os.path.getsize(f) for f in files), len(files)


def peak_rss_mib(rto, scene, out):
    # a child of its own, so that RUSAGE_CHILDREN holds this run's peak alone
    pid = os.fork()
    if pid == 0:
        try:
            render(rto, scene, out)
            ru = resource.getrusage(resource.RUSAGE_CHILDREN)
            with open(os.path.join(os.path.dirname(out), "rss"), "w") as f:
                f.write(str(ru.ru_maxrss))
            os._exit(0)
        except Exception:  # noqa: BLE001 (the parent reports a missing figure)
            os._exit(1)
    _, status = os.waitpid(pid, 0)
    if status:
        sys.exit("golden.py: the RSS run failed")
    with open(os.path.join(os.path.dirname(out), "rss")) as f:
        return int(f.read()) / 1024.0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("rtoracle")
    ap.add_argument("scene")
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--json")
    a = ap.parse_args()
    if a.runs < 5:
        sys.exit("golden.py: --runs must be at least 5 (a median of 5 or more)")
    tmp = tempfile.mkdtemp(prefix="golden.")
    try:
        out = os.path.join(tmp, "frame")
        render(a.rtoracle, a.scene, out)  # warm the page cache with the scene and the binary
        walls = [render(a.rtoracle, a.scene, out) for _ in range(a.runs)]
        nbytes, nfiles = size_of(out)
        rss = peak_rss_mib(a.rtoracle, a.scene, out)
        full = os.path.join(tmp, "full")
        full_s = render(a.rtoracle, a.scene, full, "all")
        full_bytes, full_files = size_of(full)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    med, mb, full_mb = statistics.median(walls), nbytes / 1e6, full_bytes / 1e6
    print(f"golden {os.path.basename(a.scene)} 1920x1080 sun-shadow (lean, render's default): median {med:.2f} s "
          f"wall of {a.runs} runs (min {min(walls):.2f}, max {max(walls):.2f}) on {os.cpu_count()} CPUs; "
          f"{mb:.1f} MB in {nfiles} files; peak RSS {rss:.0f} MiB")
    print(f"full dump (--stages all): {full_s:.2f} s, {full_mb:.1f} MB in {full_files} files")
    print(f"SUMMARY golden: {med:.2f} s (goal < {GOAL_S:g} s: {'met' if med < GOAL_S else 'not met'}), {mb:.1f} MB "
          f"(goal < {GOAL_MB:g} MB: {'met' if mb < GOAL_MB else 'not met'})")
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"scene": a.scene, "runs": a.runs, "cpus": os.cpu_count(), "median_s": med, "walls_s": walls,
                       "bundle_mb": mb, "files": nfiles, "peak_rss_mib": rss, "full_s": full_s,
                       "full_mb": full_mb, "full_files": full_files}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
