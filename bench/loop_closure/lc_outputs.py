#!/usr/bin/env python3
"""Figures from lc_eval's output folders (--output D) that lc_eval itself does not print, as figures JSON.

scale RUN --scale-bias S: how much of the odometry's ATE a scale error of S alone makes. The truth scaled by 1 + S
  about the start is what that error alone would give; its ATE against the truth, and the odometry's and the
  optimized trajectory's ATE against the scaled truth (what a closure can still correct).
objects TRUTH_RUN REF_RUN RUN: each object of TRUTH_RUN (the ground-truth-pose run, `--layers`) matched to the
  nearest object of its label in REF_RUN and in RUN: the median distance for each, how many of RUN's are farther
  than REF_RUN's, and each run's mean box footprint (x times y).
strays TRUTH_RUN RUN [TRUTH_RUN RUN ...]: per label, summed over the pairs, RUN's objects with no object of their
  label in TRUTH_RUN within 0.5 m (objects_eval's match radius: the estimates that cost objects correct, with the
  truth run standing in for the world's objects), and TRUTH_RUN's with none in RUN; and, of each run, the objects
  wider than --wide-m on a horizontal axis and those smaller than --piece-m on every axis (merged neighbours and
  pieces).
rooms JSON [JSON ...]: from lc_eval's figures (--json of `--layers` runs, not folders), for each of the three runs
  (gt: true poses, odometry, corrected) the mean over the runs of rooms precision, recall, their F1 (per run, then
  averaged) and the number of rooms found: whether a recall below the truth run's is rooms missed or rooms the truth
  run merges.
room_places RUN [RUN ...]: each room node of each run's scene_graph.json: its places, their extent in x and y and
  their largest clearance (which rooms a run merged, and how small they are).
world_objects WORLD RUN [WORLD RUN ...]: each run's objects against the world's (WORLD: a world file,
  drivers/world/WORLD_FORMAT.md; for a generated building `qsg_simulate --building --rooms N --seed S --no-render
  --no-gt --out D` writes D/world.json), by objects_eval's metric (same label within 0.5 m of the world object's
  centre), summed over the pairs: objects, correct, world objects found; and each incorrect object by kind: a set
  (its box, grown 0.1 m, holds in x and y the centres of two or more world objects of its label), a piece (under
  --piece-m on every axis), near (a world object of its label within 1 m: placed or sized off) or a stray (none
  within 1 m).
object_spread WORLD RUN [WORLD RUN ...] [--trim Q]: each object node's own mesh vertices (its mesh_connections into
  the run's mesh.ply) against the world's objects, by the same metric: objects correct and found with the positions
  as written, and with every centre re-taken from those vertices as the midrange of their Q..1-Q quantiles on each
  axis (Q 0: their full box), which a sparse tail of vertices cannot stretch; and, summed over the incorrect
  objects, their vertices' extent on each horizontal axis, all of them against the Q..1-Q quantiles (how much of a
  box a tail makes). mesh_connections may be a sample of an object's vertices (objects.max_keys_per_object).

RUN is a run's folder (trajectory_*.txt, scene_graph.json). Figures go to --out in the format of bench/figures.h
(name, value, unit, conditions, commit).

usage: lc_outputs.py scale RUN --scale-bias S --commit H --out F
       lc_outputs.py objects TRUTH_RUN REF_RUN RUN --commit H --out F
       lc_outputs.py strays TRUTH_RUN RUN [TRUTH_RUN RUN ...] --commit H --out F
       lc_outputs.py rooms LC_EVAL_JSON [LC_EVAL_JSON ...] --commit H --out F
       lc_outputs.py room_places RUN [RUN ...] --commit H --out F
       lc_outputs.py world_objects WORLD RUN [WORLD RUN ...] --commit H --out F
       lc_outputs.py object_spread WORLD RUN [WORLD RUN ...] [--trim Q] --commit H --out F
"""
import argparse
import json
import math
import os
import re
import statistics
import struct


def trajectory(path):
    with open(path) as f:
        return [[float(v) for v in line.split()[1:4]] for line in f if line.strip() and not line.startswith("#")]


def ate(a, b):
    return math.sqrt(sum(math.dist(p, q) ** 2 for p, q in zip(a, b)) / len(a))


def scene_graph(run):
    with open(os.path.join(run, "scene_graph.json")) as f:
        return json.load(f)


def objects(run):
    graph = scene_graph(run)
    out = []
    for n in graph["nodes"]:
        a = n["attributes"]
        if n["layer"] == 2 and "semantic_label" in a:
            out.append((a["semantic_label"], a["position"], a["bounding_box"]["dimensions"]))
    return out


def mesh_positions(run):
    """The vertex positions of a run's mesh.ply (the app's binary layout: x y z float, r g b uchar, label int)."""
    path = os.path.join(run, "mesh.ply")
    if not os.path.isfile(path):
        raise SystemExit(f"{path}: no mesh (object_spread reads the mesh an lc_eval --output folder holds)")
    with open(path, "rb") as f:
        data = f.read()
    if b"end_header\n" not in data:
        raise SystemExit(f"{path}: not a PLY file")
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode(errors="replace")
    vertices = re.search(r"element vertex (\d+)", header)
    if vertices is None or "property int label" not in header or "format binary_little_endian" not in header:
        raise SystemExit(f"{path}: not the app's binary mesh layout")
    n = int(vertices.group(1))
    if len(data) < end + 19 * n:
        raise SystemExit(f"{path}: truncated ({n} vertices declared, {(len(data) - end) // 19} present)")
    return [struct.unpack_from("<fff", data, end + 19 * i) for i in range(n)]


def quantile_range(values, q):
    xs = sorted(values)
    return xs[int(math.floor(q * (len(xs) - 1)))], xs[int(math.ceil((1.0 - q) * (len(xs) - 1)))]


def near_world(label, p, world, radius):
    """Whether a world object (label, centre) of this label lies within radius of p: objects_eval's metric."""
    return any(l == label and math.dist(p, c) <= radius for l, c in world)


def label_ids():
    """mpcat40 label name -> index, from the product's table (core/semantics/labels.cc)."""
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "core", "semantics", "labels.cc")
    with open(path) as f:
        return {m.group(2): int(m.group(1)) for m in re.finditer(r'\{(\d+), "(\w+)", \{', f.read())}


def nearest(o, others):
    d = [math.dist(o[1], p[1]) for p in others if p[0] == o[0]]
    return min(d) if d else math.inf


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=["scale", "objects", "strays", "rooms", "room_places", "world_objects",
                                     "object_spread"])
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--scale-bias", type=float, default=0.0)
    ap.add_argument("--wide-m", type=float, default=1.0)
    ap.add_argument("--piece-m", type=float, default=0.45)
    ap.add_argument("--trim", type=float, default=0.05)
    ap.add_argument("--commit", required=True)
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    figures = []

    def add(name, value, unit, conditions):
        figures.append({"name": name, "value": value, "unit": unit, "conditions": conditions, "commit": args.commit})
        print(f"{name}: {value:.4f} {unit}")

    if args.what == "scale":
        if len(args.runs) != 1:
            ap.error("scale takes one run")
        run = args.runs[0]
        truth = trajectory(os.path.join(run, "trajectory_ground_truth.txt"))
        odometry = trajectory(os.path.join(run, "trajectory_odometry.txt"))
        optimized = trajectory(os.path.join(run, "trajectory_estimate.txt"))
        s = 1.0 + args.scale_bias
        scaled = [[truth[0][k] + s * (p[k] - truth[0][k]) for k in range(3)] for p in truth]
        c = f"{run}, the truth scaled by {s} about the start"
        add("scale.ate_scale_alone", ate(scaled, truth), "m", c)
        add("scale.ate_odometry", ate(odometry, truth), "m", c)
        add("scale.ate_optimized", ate(optimized, truth), "m", c)
        add("scale.ate_odometry_to_scaled", ate(odometry, scaled), "m", c)
        add("scale.ate_optimized_to_scaled", ate(optimized, scaled), "m", c)
    elif args.what == "room_places":
        for run in args.runs:
            graph = scene_graph(run)
            kind = {n["id"]: n["attributes"].get("type") for n in graph["nodes"]}
            places = {n["id"]: n["attributes"] for n in graph["nodes"] if kind[n["id"]] == "PlaceNodeAttributes"}
            room_of = {}
            for e in graph["edges"]:
                for room, place in ((e["source"], e["target"]), (e["target"], e["source"])):
                    if kind.get(room) == "RoomNodeAttributes" and place in places:
                        room_of[place] = room
            rooms = sorted(set(room_of.values()))
            c = f"the room nodes of {run}/scene_graph.json and the places under each"
            for k, room in enumerate(rooms):
                ps = [places[p] for p, r in room_of.items() if r == room]
                xs = [p["position"][0] for p in ps]
                ys = [p["position"][1] for p in ps]
                name = f"{os.path.basename(os.path.normpath(run))}.room{k}"
                add(f"{name}.places", len(ps), "places", c)
                add(f"{name}.x_extent", max(xs) - min(xs), "m", c)
                add(f"{name}.y_extent", max(ys) - min(ys), "m", c)
                add(f"{name}.x_min", min(xs), "m", c)
                add(f"{name}.y_min", min(ys), "m", c)
                add(f"{name}.largest_clearance", max(p["distance"] for p in ps), "m", c)
    elif args.what == "rooms":
        values = {}
        for path in args.runs:
            with open(path) as f:
                for e in json.load(f):
                    values[e["name"]] = e["value"]
        runs = sorted({n.split(".")[0] for n in values if n.endswith(".gt.rooms_precision")})
        if not runs:
            ap.error("rooms: no run with gt.rooms_precision in the files (lc_eval --layers)")
        c = f"{len(runs)} runs ({' '.join(runs)}) of {' '.join(args.runs)}"
        for kind in ("gt", "odometry", "corrected"):
            p = [values[f"{r}.{kind}.rooms_precision"] for r in runs]
            r_ = [values[f"{r}.{kind}.rooms_recall"] for r in runs]
            f1 = [2 * a * b / (a + b) if a + b > 0 else 0.0 for a, b in zip(p, r_)]
            add(f"rooms.{kind}.precision_mean", statistics.mean(p), "ratio", c)
            add(f"rooms.{kind}.recall_mean", statistics.mean(r_), "ratio", c)
            add(f"rooms.{kind}.f1_mean", statistics.mean(f1), "ratio", c)
            add(f"rooms.{kind}.rooms_mean", statistics.mean(values[f"{r}.{kind}.rooms"] for r in runs), "rooms", c)
    elif args.what == "world_objects":
        if len(args.runs) % 2 != 0:
            ap.error("world_objects takes pairs WORLD RUN")
        ids = label_ids()
        radius, near_m, grow = 0.5, 1.0, 0.1
        count = {k: 0 for k in ("objects", "correct", "world", "found", "set", "piece", "near", "stray")}
        by_label = {}
        for world_path, run_dir in zip(args.runs[0::2], args.runs[1::2]):
            with open(world_path) as f:
                world = [(ids[o["label"]], o["center"]) for o in json.load(f)["objects"]]
            run = objects(run_dir)
            count["objects"] += len(run)
            count["world"] += len(world)
            found = set()
            for label, pos, dims in run:
                d = [(math.dist(pos, c), i) for i, (l, c) in enumerate(world) if l == label]
                hits = [i for dist, i in d if dist <= radius]
                found.update(hits)
                if hits:
                    count["correct"] += 1
                    continue
                inside = sum(1 for l, c in world if l == label and
                             all(abs(c[k] - pos[k]) <= dims[k] / 2 + grow for k in range(2)))
                dist = min(d)[0] if d else math.inf
                kind = ("set" if inside >= 2 else "piece" if max(dims) < args.piece_m else
                        "near" if dist <= near_m else "stray")
                count[kind] += 1
                by_label.setdefault(label, {}).setdefault(kind, 0)
                by_label[label][kind] += 1
            count["found"] += len(found)
        c = (f"objects of {' '.join(args.runs[1::2])} against the world objects of {' '.join(args.runs[0::2])}: "
             f"same label within {radius} m of the centre; incorrect ones by kind (set: box grown {grow} m holds in x, y two "
             f"or more of the label's centres; piece: under {args.piece_m} m; near: one within {near_m} m; stray)")
        add("world_objects.objects", count["objects"], "objects", c)
        add("world_objects.correct", count["correct"], "objects", c)
        add("world_objects.correct_share", 100.0 * count["correct"] / max(1, count["objects"]), "%", c)
        add("world_objects.world", count["world"], "objects", c)
        add("world_objects.found", count["found"], "objects", c)
        for kind in ("set", "piece", "near", "stray"):
            add(f"world_objects.incorrect_{kind}", count[kind], "objects", c)
        for label in sorted(by_label):
            for kind, n in sorted(by_label[label].items()):
                add(f"world_objects.label{label}.incorrect_{kind}", n, "objects", c)
    elif args.what == "object_spread":
        if len(args.runs) % 2 != 0:
            ap.error("object_spread takes pairs WORLD RUN")
        if not 0.0 <= args.trim < 0.5:
            ap.error("--trim must be in [0, 0.5)")
        ids = label_ids()
        radius = 0.5
        variants = ("as_written", "vertex_box", "trimmed")
        count = {v: {"objects": 0, "correct": 0, "found": 0} for v in variants}
        world_total = 0
        spread = {"objects": 0, "all_m": 0.0, "trimmed_m": 0.0}
        for world_path, run_dir in zip(args.runs[0::2], args.runs[1::2]):
            with open(world_path) as f:
                world = [(ids[o["label"]], o["center"]) for o in json.load(f)["objects"]]
            world_total += len(world)
            vertices = mesh_positions(run_dir)
            centres = {v: [] for v in variants}
            incorrect_points = []
            for n in scene_graph(run_dir)["nodes"]:
                a = n["attributes"]
                if n["layer"] != 2 or "semantic_label" not in a:
                    continue
                label, pos = a["semantic_label"], a["position"]
                links = a.get("mesh_connections", [])
                links = json.loads(links) if isinstance(links, str) else links
                points = [vertices[i] for i in links if 0 <= i < len(vertices)]
                centres["as_written"].append((label, pos))
                for v, q in (("vertex_box", 0.0), ("trimmed", args.trim)):
                    c = [sum(quantile_range([p[k] for p in points], q)) / 2 for k in range(3)] if points else pos
                    centres[v].append((label, c))
                if points and not near_world(label, pos, world, radius):
                    incorrect_points.append(points)
            for v in variants:
                count[v]["objects"] += len(centres[v])
                count[v]["correct"] += sum(1 for label, p in centres[v] if near_world(label, p, world, radius))
                count[v]["found"] += sum(1 for l, c in world if near_world(l, c, centres[v], radius))
            for points in incorrect_points:
                spread["objects"] += 1
                for k in range(2):
                    xs = [p[k] for p in points]
                    lo, hi = quantile_range(xs, args.trim)
                    spread["all_m"] += max(xs) - min(xs)
                    spread["trimmed_m"] += hi - lo
        c = (f"objects of {' '.join(args.runs[1::2])} against the world objects of {' '.join(args.runs[0::2])}: same "
             f"label within {radius} m of the centre; as written, and with each centre re-taken from the node's own "
             f"mesh vertices (mesh_connections into mesh.ply) as the midrange of their full range (vertex_box) or of "
             f"their {args.trim}..{1 - args.trim} quantiles per axis (trimmed)")
        add("object_spread.world", world_total, "objects", c)
        for v in variants:
            add(f"object_spread.{v}.objects", count[v]["objects"], "objects", c)
            add(f"object_spread.{v}.correct", count[v]["correct"], "objects", c)
            add(f"object_spread.{v}.correct_share", 100.0 * count[v]["correct"] / max(1, count[v]["objects"]), "%", c)
            add(f"object_spread.{v}.found", count[v]["found"], "objects", c)
        add("object_spread.incorrect.objects", spread["objects"], "objects", c)
        add("object_spread.incorrect.horizontal_extent_all", spread["all_m"], "m", c)
        add("object_spread.incorrect.horizontal_extent_trimmed", spread["trimmed_m"], "m", c)
    elif args.what == "strays":
        if len(args.runs) % 2 != 0:
            ap.error("strays takes pairs TRUTH_RUN RUN")
        radius = 0.5
        stray, missed, total = {}, {}, {}
        wide = {"run": {}, "truth_run": {}}
        pieces = {"run": {}, "truth_run": {}}

        def shape(which, o):
            dims = o[2]
            wide[which][o[0]] = wide[which].get(o[0], 0) + (max(dims[0], dims[1]) > args.wide_m)
            pieces[which][o[0]] = pieces[which].get(o[0], 0) + (max(dims) < args.piece_m)

        for truth_dir, run_dir in zip(args.runs[0::2], args.runs[1::2]):
            truth, run = objects(truth_dir), objects(run_dir)
            for o in run:
                total[o[0]] = total.get(o[0], 0) + 1
                stray[o[0]] = stray.get(o[0], 0) + (nearest(o, truth) > radius)
                shape("run", o)
            for o in truth:
                missed[o[0]] = missed.get(o[0], 0) + (nearest(o, run) > radius)
                shape("truth_run", o)
        c = f"objects of {' '.join(args.runs[1::2])} against {' '.join(args.runs[0::2])}, same label within {radius} m"
        for label in sorted(set(stray) | set(missed)):
            add(f"strays.label{label}.objects", total.get(label, 0), "objects", c)
            add(f"strays.label{label}.no_truth_run_object_near", stray.get(label, 0), "objects", c)
            add(f"strays.label{label}.truth_run_objects_missed", missed.get(label, 0), "objects", c)
            for which in ("run", "truth_run"):
                add(f"strays.label{label}.{which}_wider_than_{args.wide_m}m", wide[which].get(label, 0), "objects", c)
                add(f"strays.label{label}.{which}_under_{args.piece_m}m", pieces[which].get(label, 0), "objects", c)
    else:
        if len(args.runs) != 3:
            ap.error("objects takes TRUTH_RUN REF_RUN RUN")
        truth, ref, run = (objects(r) for r in args.runs)
        c = f"objects of {args.runs[0]} matched by label in {args.runs[1]} (ref) and {args.runs[2]} (run)"
        d_ref = [nearest(o, ref) for o in truth]
        d_run = [nearest(o, run) for o in truth]
        add("objects.truth_run", len(truth), "objects", c)
        add("objects.ref_median_distance", statistics.median(d_ref), "m", c)
        add("objects.run_median_distance", statistics.median(d_run), "m", c)
        add("objects.run_farther_than_ref", sum(r > f + 0.005 for r, f in zip(d_run, d_ref)), "objects", c)
        for name, objs in (("truth_run", truth), ("ref", ref), ("run", run)):
            add(f"objects.{name}_mean_footprint", statistics.mean(d[0] * d[1] for _, _, d in objs), "m^2", c)
    with open(args.out, "w") as f:
        json.dump(figures, f, indent=1)


if __name__ == "__main__":
    main()
