#!/usr/bin/env python3
"""Per-solve lines of a qsg_app or lc_eval log ("loop closure: solve at T s, P m of path: ...") as figures JSON.

lc_eval writes its JSON at the end of a run; a long run stopped before its end (a 1,000 m mission whose solves
outgrow the machine) still has one line per solve. This turns them into the figures format of bench/figures.h
(name, value, unit, conditions, commit): every solve's path, graph size and CPU time, and the median and maximum
CPU per 50 m of path.

usage: solve_log_to_json.py LOG --conditions TEXT --commit HASH --out FILE
"""
import argparse
import json
import re
import statistics
import sys

LINE = re.compile(r"loop closure: solve at (\d+) s, ([\d.]+) m of path: (\d+) agents, (\d+) control points, "
                  r"(\d+) places, (\d+) closures \((\d+) kept\): ([\d.]+) ms CPU")
# Logs from 2026-12-03 (5) on: "built in X ms CPU under the graph lock"; from 2026-12-04 on the inputs are copied
# under the lock ("inputs copied in X ms CPU under the graph lock, built in Y ms CPU") and built without it.
BUILD = re.compile(r"built in ([\d.]+) ms CPU")
LOCK = re.compile(r"copied in ([\d.]+) ms CPU under the graph lock")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("log")
    ap.add_argument("--conditions", required=True)
    ap.add_argument("--commit", required=True)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    rows = []
    with open(a.log, encoding="utf-8", errors="replace") as f:
        for line in f:
            m = LINE.search(line)
            if m:
                b = BUILD.search(line)
                k = LOCK.search(line)
                rows.append([float(x) for x in m.groups()] + [float(b.group(1)) if b else None,
                                                               float(k.group(1)) if k else None])
    if not rows:
        sys.exit(f"{a.log}: no 'loop closure: solve at' lines")
    figures = []

    def add(name, value, unit):
        figures.append({"name": name, "value": value, "unit": unit, "conditions": a.conditions, "commit": a.commit})

    for i, (t, path, agents, cps, places, closures, kept, cpu, build, lock) in enumerate(rows):
        p = f"solve.{i}."
        add(p + "time", t, "s")
        add(p + "path", path, "m")
        add(p + "agents", agents, "count")
        add(p + "control_points", cps, "count")
        add(p + "places", places, "count")
        add(p + "closures", closures, "count")
        add(p + "cpu", cpu, "ms")
        if build is not None:
            add(p + "build_cpu", build, "ms")
        if lock is not None:
            add(p + "lock_cpu", lock, "ms")
    last = int(rows[-1][1] // 50)
    for b in range(last + 1):
        cpu = [r[7] for r in rows if b * 50 <= r[1] < (b + 1) * 50]
        if cpu:
            add(f"path_{b * 50}_{(b + 1) * 50}m.cpu_median", statistics.median(cpu), "ms")
            add(f"path_{b * 50}_{(b + 1) * 50}m.cpu_max", max(cpu), "ms")
            add(f"path_{b * 50}_{(b + 1) * 50}m.solves", len(cpu), "count")
    with open(a.out, "w", encoding="utf-8") as f:
        json.dump(figures, f, indent=1)
    print(f"{len(rows)} solves, last at {rows[-1][1]:.1f} m: {rows[-1][7]:.0f} ms CPU -> {a.out}")


if __name__ == "__main__":
    main()
