#!/usr/bin/env python3
"""Deterministic ARM instruction counts per stage and per keyframe of the main job, with expected milliseconds.

Runs the arm64 build of qsg_app (the xavier_nx table) under qemu-aarch64 with bench/arm/insn_count_plugin.c, in
lockstep with --deterministic and --stage-markers, so every timed stage run (the table's tasks, the backend and
segmentation threads, the backend's door pass and final stage) is counted in guest instructions. From the counts
and a cycles-per-instruction assumption for the Xavier NX's Carmel cores (bench/results/arm_insn.md) it gives the
expected milliseconds per run against each stage's budget. Writes [{name, value, unit, conditions, commit}] to
OUT_DIR/<commit>.json (one file per commit) and compares it with the file of the nearest earlier commit.

  bench/arm/insn_counts.py [--duration 30] [--repeat 2] [--cpi 1.0] [--clock-ghz 1.4]   (from the repository root)
  bench/arm/insn_counts.py --compare OLD.json NEW.json      (exit 1 when an instruction figure grew > 1 %)
  bench/arm/insn_counts.py --table RESULT.json              (the results log's table)
"""
import argparse
import concurrent.futures
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PLUGIN_SOURCE = os.path.join(ROOT, "bench", "arm", "insn_count_plugin.c")


def run(cmd, **kwargs):
    return subprocess.run(cmd, check=True, **kwargs)


def git(*args):
    return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True).stdout.strip()


def build_plugin(out_dir):
    """The plugin is a host library: built here with the host C compiler (a cross build has none of its own)."""
    os.makedirs(out_dir, exist_ok=True)
    so = os.path.join(out_dir, "insn_count_plugin.so")
    if not os.path.exists(so) or os.path.getmtime(so) < os.path.getmtime(PLUGIN_SOURCE):
        cc = os.environ.get("CC", "cc")
        run([cc, "-O2", "-Wall", "-Wextra", "-fvisibility=hidden", "-shared", "-fPIC", "-o", so, PLUGIN_SOURCE,
             "-lpthread"])
    return so


def run_app(args, plugin, work):
    """One run of the app under the plugin; returns (stage table, keyframes, runs per stage, total instructions)."""
    out = os.path.join(work, "runs.txt")
    log = os.path.join(work, "app.log")
    cmd = [args.qemu, "-L", args.sysroot, "-plugin", f"{plugin},out={out}", args.app, "--deterministic",
           "--stage-markers", "--quiet", "--duration", str(args.duration), "--output", os.path.join(work, "out")]
    if args.rooms:
        cmd += ["--rooms", str(args.rooms)]
    for s in args.set or []:
        cmd += ["--set", s]
    print("running:", " ".join(cmd), flush=True)
    with open(log, "w") as f:
        rc = subprocess.run(cmd, cwd=ROOT, stdout=f, stderr=subprocess.STDOUT).returncode
    if rc != 0:
        sys.exit(f"insn_counts: the app exited with {rc}; see {log}")
    stages, keyframes, board, solves = {}, 0, "?", {}
    with open(log) as f:
        for line in f:
            # With loop closure on, the graph's size beside each marked solve (keyed by its sequence, the time).
            m = re.match(r"loop_closure_solve (\d+) (.*)$", line)
            if m:
                solves[int(m.group(1))] = {k: int(v) for k, v in re.findall(r"(\w+)=(\d+)", m.group(2))}
            m = re.match(r"stage_marker (\d+) (\S+) (\d+)$", line)
            if m:
                stages[int(m.group(1))] = (m.group(2), int(m.group(3)))
            m = re.match(r"run: \d+ frames, (\d+) keyframes", line)
            if m:
                keyframes = int(m.group(1))
            m = re.match(r"qsg_app: board (\S+)", line)
            if m:
                board = m.group(1)
    runs, total, unmatched = {}, 0, 0
    with open(out) as f:
        for line in f:
            p = line.split()
            if p[0] == "run":
                runs.setdefault(int(p[1]), []).append((int(p[2]), int(p[3])))
            elif p[0] == "total":
                total = int(p[1])
            elif p[0] == "unmatched":
                unmatched = int(p[1])
    if not stages or keyframes == 0:
        sys.exit(f"insn_counts: no stage table or no keyframe in {log} (is the app built with --stage-markers?)")
    if unmatched:
        sys.exit(f"insn_counts: {unmatched} unmatched end markers in {out}")
    if args.keep_logs:
        os.makedirs(args.keep_logs, exist_ok=True)
        tag = os.path.basename(work)
        shutil.copy(log, os.path.join(args.keep_logs, tag + ".app.log"))
        shutil.copy(out, os.path.join(args.keep_logs, tag + ".runs.txt"))
    return stages, keyframes, board, runs, total, solves


def quantile(sorted_values, q):
    """Nearest-rank quantile."""
    k = max(1, math.ceil(q * len(sorted_values)))
    return sorted_values[k - 1]


def figures_of(stages, keyframes, runs, total, args, commit, conditions, solves=None):
    figs = []

    def add(name, value, unit):
        figs.append({"name": name, "value": value, "unit": unit, "conditions": conditions, "commit": commit})

    ms_per_insn = args.cpi / (args.clock_ghz * 1e6)
    add("arm_insn.keyframes", keyframes, "keyframes")
    add("arm_insn.process.instructions", total, "instructions")
    loop_total = 0
    for sid in sorted(stages):
        name, budget_us = stages[sid]
        counts = sorted(c for _, c in runs.get(sid, []))
        if not counts:
            continue
        s = sum(counts)
        if sid < 64:  # tasks and threads; the backend's parts are inside its updates
            loop_total += s
        p = f"arm_insn.{name}."
        add(p + "runs", len(counts), "runs")
        add(p + "instructions", s, "instructions")
        add(p + "instructions_per_keyframe", s / keyframes, "instructions")
        add(p + "instructions_per_run_mean", s / len(counts), "instructions")
        add(p + "instructions_per_run_p99", quantile(counts, 0.99), "instructions")
        add(p + "instructions_per_run_max", counts[-1], "instructions")
        add(p + "expected_ms_mean", s / len(counts) * ms_per_insn, "ms")
        add(p + "expected_ms_max", counts[-1] * ms_per_insn, "ms")
        add(p + "budget_ms", budget_us / 1000.0, "ms")
        add(p + "expected_max_share_of_budget", counts[-1] * ms_per_insn / (budget_us / 1000.0), "ratio")
        add(p + "expected_runs_over_budget", sum(1 for c in counts if c * ms_per_insn > budget_us / 1000.0), "runs")
    add("arm_insn.loop.instructions_per_keyframe", loop_total / keyframes, "instructions")
    # Each online loop-closure solve with the size of its graph (the app prints them with --stage-markers).
    for sid, (name, _) in sorted(stages.items()):
        if name != "loop_closure_solve":
            continue
        for k, (seq, count) in enumerate(runs.get(sid, [])):
            p = f"arm_insn.{name}.solve_{k}."
            add(p + "time_s", seq * 1e-9, "s")
            add(p + "instructions", count, "instructions")
            add(p + "expected_ms", count * ms_per_insn, "ms")
            for key, value in sorted((solves or {}).get(seq, {}).items()):
                add(p + key, value, "count")
    return figs


def print_solves(figs):
    """The per-solve lines of a result file: time, graph size, instructions, expected ms."""
    value = {f["name"]: f["value"] for f in figs}
    k = 0
    while f"arm_insn.loop_closure_solve.solve_{k}.instructions" in value:
        if k == 0:
            print("\n| solve at s | agents | control points | places | loop closures | instructions | expected ms |")
            print("| ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
        p = f"arm_insn.loop_closure_solve.solve_{k}."
        print(f"| {value[p + 'time_s']:.1f} | {value.get(p + 'agents', 0):.0f} | {value.get(p + 'control_points', 0):.0f} "
              f"| {value.get(p + 'places', 0):.0f} | {value.get(p + 'loop_closures', 0):.0f} | "
              f"{value[p + 'instructions']:,.0f} | {value[p + 'expected_ms']:.1f} |")
        k += 1


def commit_time(commit):
    t = git("log", "-1", "--format=%ct", commit.replace("-dirty", ""))
    return int(t) if t.isdigit() else None


def previous_file(out_dir, commit):
    """The file of the nearest earlier commit that is an ancestor of this one (or the newest other file)."""
    best, best_time = None, -1
    for f in sorted(os.listdir(out_dir)):
        if not f.endswith(".json") or f == commit + ".json":
            continue
        c = f[:-5]
        t = commit_time(c)
        if t is None:
            continue
        ancestor = subprocess.run(["git", "merge-base", "--is-ancestor", c.replace("-dirty", ""), "HEAD"],
                                  cwd=ROOT).returncode == 0
        if ancestor and t > best_time:
            best, best_time = os.path.join(out_dir, f), t
    return best


def compare(old_path, new_path, threshold_pct):
    """Prints every instruction figure's change; returns how many grew by more than threshold_pct."""
    old = {f["name"]: f for f in json.load(open(old_path))}
    new = {f["name"]: f for f in json.load(open(new_path))}
    strip = lambda c: re.sub(r"; expected ms at .*", "", c)  # the CPI assumption does not change the counts
    if old and new and strip(next(iter(old.values()))["conditions"]) != strip(next(iter(new.values()))["conditions"]):
        print("\nwarning: the two files were measured under different conditions; changes are not regressions")
    print(f"\ncompared with {os.path.basename(old_path)} (instruction figures; > {threshold_pct} % flagged):")
    print(f"  {'figure':58} {'old':>15} {'new':>15} {'change':>9}")
    grown = 0
    for name in sorted(set(old) | set(new)):
        unit = (new.get(name) or old.get(name))["unit"]
        if unit != "instructions":
            continue
        a = old.get(name, {}).get("value")
        b = new.get(name, {}).get("value")
        if a is None or b is None:
            print(f"  {name:58} {a if a is not None else '-':>15} {b if b is not None else '-':>15}")
            continue
        pct = 100.0 * (b - a) / a if a else 0.0
        flag = ""
        if pct > threshold_pct:
            flag, grown = "  REGRESSION", grown + 1
        elif pct < -threshold_pct:
            flag = "  fewer"
        print(f"  {name:58} {a:15.0f} {b:15.0f} {pct:+8.2f}%{flag}")
    return grown


def markdown(figs, cpi_low, cpi_high):
    """The results log's table from a result file's figures (expected ms at the file's CPI, and the range)."""
    value = {f["name"]: f["value"] for f in figs}
    stages = [n[len("arm_insn."):-len(".budget_ms")] for n in value if n.endswith(".budget_ms")]
    m = re.search(r"CPI ([0-9.]+) and ([0-9.]+) GHz", figs[0]["conditions"])
    cpi, ghz = float(m.group(1)), float(m.group(2))
    print(f"\n| stage | runs | instructions per run: mean / p99 / max | per keyframe | expected ms per run: mean / "
          f"max at CPI {cpi:g}, {ghz:g} GHz | max at CPI {cpi_low:g}-{cpi_high:g} | budget ms | max / budget at CPI "
          f"{cpi:g} |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for s in stages:
        p = f"arm_insn.{s}."
        ms_max = value[p + "expected_ms_max"]
        print(f"| {s} | {value[p + 'runs']:.0f} | {value[p + 'instructions_per_run_mean']:,.0f} / "
              f"{value[p + 'instructions_per_run_p99']:,.0f} / {value[p + 'instructions_per_run_max']:,.0f} | "
              f"{value[p + 'instructions_per_keyframe']:,.0f} | {value[p + 'expected_ms_mean']:.3f} / {ms_max:.3f} | "
              f"{ms_max * cpi_low / cpi:.3f}-{ms_max * cpi_high / cpi:.3f} | {value[p + 'budget_ms']:g} | "
              f"{100 * value[p + 'expected_max_share_of_budget']:.1f} % |")
    print(f"\n{value['arm_insn.keyframes']:.0f} keyframes; the loop's tasks and threads "
          f"{value['arm_insn.loop.instructions_per_keyframe']:,.0f} instructions per keyframe; the whole process "
          f"{value['arm_insn.process.instructions']:,.0f} (start-up, the simulator's rendering and the outputs "
          f"included); repeats' largest relative difference {value['arm_insn.repeat_max_relative_difference']:.2e}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--app", default=os.path.join(ROOT, "build/arm64/firmware_app/qsg_app"))
    ap.add_argument("--sysroot", default=os.path.join(ROOT, "build/sysroots/bookworm-arm64"))
    ap.add_argument("--qemu", default=shutil.which("qemu-aarch64") or "qemu-aarch64")
    ap.add_argument("--duration", type=float, default=30.0, help="simulated seconds of the mission (default 30)")
    ap.add_argument("--rooms", type=int, default=0, help="rooms of the generated building (default: the config's)")
    ap.add_argument("--set", action="append", help="a config key for the app, SECTION.KEY=VALUE")
    ap.add_argument("--repeat", type=int, default=2, help="runs; every run must count the same (default 2)")
    ap.add_argument("--jobs", type=int, default=1, help="repeats run at once (one core each)")
    ap.add_argument("--cpi", type=float, default=1.0, help="Carmel cycles per instruction (bench/results/arm_insn.md)")
    ap.add_argument("--cpi-low", type=float, default=0.7)
    ap.add_argument("--cpi-high", type=float, default=2.0)
    ap.add_argument("--clock-ghz", type=float, default=1.4, help="Carmel clock (Xavier NX 15 W, 6 cores: 1.4 GHz)")
    ap.add_argument("--out-dir", default=os.path.join(ROOT, "bench/results/arm_insn"))
    ap.add_argument("--threshold-pct", type=float, default=1.0, help="growth flagged as a regression")
    ap.add_argument("--no-build", action="store_true", help="do not (re)build the arm64 qsg_app first")
    ap.add_argument("--commit", help="the commit --app was built from, when it is not this tree's (another "
                    "worktree's build); names the result file")
    ap.add_argument("--keep-logs", metavar="DIR", help="copy each run's app log and runs file (plugin output) here")
    ap.add_argument("--compare", nargs=2, metavar=("OLD", "NEW"), help="only compare two result files")
    ap.add_argument("--table", metavar="RESULT", help="only print the results log's table of a result file")
    args = ap.parse_args()
    if args.compare:
        return 1 if compare(args.compare[0], args.compare[1], args.threshold_pct) else 0
    if args.table:
        markdown(json.load(open(args.table)), args.cpi_low, args.cpi_high)
        print_solves(json.load(open(args.table)))
        return 0

    if not args.no_build:
        run(["cmake", "--build", "--preset", "arm64", "--target", "qsg_app", "-j2"], cwd=ROOT)
    if not os.path.exists(args.app):
        sys.exit(f"insn_counts: no arm64 app at {args.app} (cmake --preset arm64 && cmake --build --preset arm64 "
                 "--target qsg_app)")
    plugin = build_plugin(os.path.join(ROOT, "build", "arm_insn"))
    commit = args.commit or git("describe", "--always", "--dirty=-dirty", "--abbrev=12") or "unknown"
    qemu_version = subprocess.run([args.qemu, "--version"], capture_output=True, text=True).stdout.split("\n")[0]

    def one_run(_):
        with tempfile.TemporaryDirectory(prefix="arm_insn_") as work:
            return run_app(args, plugin, work)

    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        results = list(pool.map(one_run, range(args.repeat)))
    stages, keyframes, board, runs, total, solves = results[0]
    # Repeats must agree. Exactly, but for bookkeeping that reads the host: telemetry prints the resident set, and
    # the backend keeps the longest wall-clock durations (a store or not): tens of instructions, explained in
    # bench/results/arm_insn.md. More than the tolerance apart is a real non-determinism and fails the run;
    # telemetry, whose whole output is host figures (resident set, page faults), is held to 1e-2.
    identical = all(r[1:5] == results[0][1:5] for r in results[1:])
    tolerance = 1e-3
    worst = failing = 0.0
    for sid in sorted(stages):
        for j, r in enumerate(results[1:], 2):
            if r[3].get(sid) != runs.get(sid):
                a = sum(c for _, c in runs.get(sid, []))
                b = sum(c for _, c in r[3].get(sid, []))
                rel = abs(a - b) / max(a, 1)
                rel = rel if len(r[3].get(sid, [])) == len(runs.get(sid, [])) else 1.0
                worst = max(worst, rel)
                failing = max(failing, rel / (10 if stages[sid][0] == "telemetry" else 1))
                print(f"insn_counts: run {j} differs on {stages[sid][0]}: {a} vs {b} instructions "
                      f"({len(runs.get(sid, []))} vs {len(r[3].get(sid, []))} runs, {rel:.2e} relative)")
    if results[0][1] != results[-1][1]:
        worst = failing = 1.0
    print(f"insn_counts: {args.repeat} run(s), counts {'identical' if identical else 'differ'}; largest relative "
          f"difference of a stage's total {worst:.2e} (tolerance {tolerance:g})")

    conditions = (f"board {board}, arm64 build (build/arm64, RelWithDebInfo, GCC cross), {qemu_version} with "
                  f"bench/arm/insn_count_plugin.c; qsg_app --deterministic --stage-markers --duration "
                  f"{args.duration:g}" + (f" --rooms {args.rooms}" if args.rooms else "") +
                  "".join(f" --set {s}" for s in args.set or []) +
                  f" (lockstep, simulated robot); expected ms at CPI {args.cpi} and {args.clock_ghz} GHz "
                  f"(Carmel assumption, bench/results/arm_insn.md); {args.repeat} runs")
    figs = figures_of(stages, keyframes, runs, total, args, commit, conditions, solves)
    figs.append({"name": "arm_insn.runs_identical", "value": 1 if identical else 0, "unit": "bool",
                 "conditions": conditions, "commit": commit})
    figs.append({"name": "arm_insn.repeat_max_relative_difference", "value": worst, "unit": "ratio",
                 "conditions": conditions, "commit": commit})
    os.makedirs(args.out_dir, exist_ok=True)
    path = os.path.join(args.out_dir, commit + ".json")
    with open(path, "w") as f:
        json.dump(figs, f, indent=2)
        f.write("\n")
    print(f"wrote {path}")
    markdown(figs, args.cpi_low, args.cpi_high)
    print_solves(figs)
    prev = previous_file(args.out_dir, commit)
    if prev:
        compare(prev, path, args.threshold_pct)
    else:
        print("\nno earlier commit's file to compare with")
    return 0 if failing <= tolerance else 1


if __name__ == "__main__":
    sys.exit(main())
