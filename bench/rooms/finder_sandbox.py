#!/usr/bin/python3
"""Sandbox for room-finder ideas: a Python mirror of core/rooms' persistence seeding, closed-off regions, flood fill,
extent split, corridor merge and visibility merge with its test near the boundary (its sight lines from the dump's
surface, one slice at the doors' height, thick islands as furniture; numpy), run on the places that
`rooms_eval --dump-places DIR` wrote, scored per place against the ground-truth rooms.

    build/release/bench/rooms/rooms_eval --cache-dir C --generated 0 --dump-places D   # once (cached: seconds)
    /usr/bin/python3 bench/rooms/finder_sandbox.py D [--config FILE] [--set SECTION.KEY=VALUE ...] [--door-oracle-m C]

Its settings are the room finder's and the door stage's, read from firmware_app/config/default.json (written by
`qsg_app --dump-config` from the parameter tables, so the mirror never restates a default) or from --config FILE in
the same form; --set rooms.KEY=VALUE or doors.KEY=VALUE changes one, as rooms_eval's --set does: e.g.
--set rooms.merge_visible=false (no numpy needed then), --set rooms.min_persistence_m=0.5,
--set doors.sight_min_wall_m=2.5. The mirror has persistence seeding without a door-clearance limit only.

It prints, per variant (plain, furnished), the same place-level score for the C++ rooms of the dump and for this
mirror, so a change tried here first can be judged in well under a second before it is written in C++. The mirror
follows the C++ closely, not exactly (ties among equal clearances fall in the dump's order, not the ids'): on
session 16's graphs, plain, 149 rooms against the C++ 150 with the corridor merge off, the same 136 with it on on
session 17's; with the visibility merge (session 19's graphs), plain 130 against 128 and furnished the same 178 with
the same score; with the thick islands as furniture and the test near the boundary, on the same graphs, plain 120
against 118 and furnished 150 against 149 (proxy furnished R 0.909 against 0.911); with rooms adjacent also by
places whose spheres touch in sight (session 21, the same graphs), plain 120 against 119 and furnished 145 against
143. The dump's place edges already carry the final stage's closures (doors and edges through walls). Compare a
change against the mirror's own baseline. The score is a proxy of rooms_eval's: it
counts places, not free cells (max-overlap precision per estimated room and recall per ground-truth room, means over
rooms, and the precision weighted by places); places outside every ground-truth room are left out, and a place
without a room counts as a room of its own. The real figures stay rooms_eval's.
"""
import argparse
import collections
import glob
import heapq
import json
import math
import os

DEFAULT_CONFIG = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "firmware_app", "config",
                              "default.json")


def load(path):
    """Places {id: dict(x, y, z, d, room, truth, plan_d)} and edges [(a, b, weight or -1)] of one dump file."""
    places, edges = {}, []
    with open(path) as f:
        for line in f:
            t = line.split()
            if t[0] == "P":
                places[int(t[1])] = dict(x=float(t[2]), y=float(t[3]), z=float(t[4]), d=float(t[5]),
                                         room=int(t[6]), truth=int(t[7]), plan_d=float(t[8]))
            elif t[0] == "E":
                edges.append((int(t[1]), int(t[2]), float(t[3])))
    return places, edges


def find_rooms(places, edges, min_component, min_persistence_m, d_min, d_max, closed_regions=True):
    """Room index per place id (-1: none), as RoomFinder with Seeding::kPersistence (no door-clearance limit)."""
    ids = list(places)
    index = {p: i for i, p in enumerate(ids)}
    n = len(ids)
    clearance = [places[p]["d"] for p in ids]
    edge_list = []
    for a, b, w in edges:
        i, j = index[a], index[b]
        c = min(clearance[i], clearance[j])
        # weight <= 0: a passage a door stage closed (RoomFinder's kClosed, below every clearance); -1: unweighted
        edge_list.append((-1.0 if w <= 0 and w != -1.0 else (min(c, w) if w >= 0 else c), i, j))
    adjacency = [[] for _ in range(n)]
    for c, i, j in edge_list:
        adjacency[i].append((c, j))
        adjacency[j].append((c, i))
    edge_order = sorted(range(len(edge_list)), key=lambda k: (-edge_list[k][0], k))
    node_order = sorted(range(n), key=lambda i: (-clearance[i], i))
    parent, size, birth, members, split = [None] * n, [0] * n, [0.0] * n, [None] * n, [False] * n
    room = [-1] * n
    rooms = [0]

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    def worthy(r, at):
        return split[r] or (size[r] >= min_component and birth[r] - at >= min_persistence_m - 1e-9)

    def emit(r):
        split[r] = True
        for i in members[r]:
            room[i] = rooms[0]
        rooms[0] += 1

    def enter(i):
        parent[i], size[i], birth[i], members[i], split[i] = i, 1, min(clearance[i], d_max), [i], False

    entered = 0
    for k in edge_order:
        c, a, b = edge_list[k]
        if c < d_min - 1e-9:
            break
        while entered < n and clearance[node_order[entered]] >= c:
            enter(node_order[entered])
            entered += 1
        ra, rb = find(a), find(b)
        if ra == rb:
            continue
        now_split = split[ra] or split[rb]
        if worthy(ra, c) and worthy(rb, c):
            for r in (ra, rb):
                if not split[r]:
                    emit(r)
            now_split = True
        if size[ra] < size[rb]:
            ra, rb = rb, ra
        parent[rb] = ra
        size[ra] += size[rb]
        birth[ra] = max(birth[ra], birth[rb])
        members[ra] += members[rb]
        members[rb] = None
        split[ra] = now_split
    while entered < n and clearance[node_order[entered]] >= d_min - 1e-9:
        enter(node_order[entered])
        entered += 1
    for t in range(entered):
        i = node_order[t]
        if parent[i] == i and not split[i] and size[i] >= min_component:
            emit(i)
    # Closed-off regions (Config::seed_closed_regions): each piece of the graph that the closed edges cut off, holds
    # no seed and has at least min_component places is a room of its own.
    if closed_regions and any(c < 0 for c, _, _ in edge_list):
        region = list(range(n))

        def region_of(i):
            while region[i] != i:
                region[i] = region[region[i]]
                i = region[i]
            return i

        for c, i, j in edge_list:
            if c >= 0:
                a, b = region_of(i), region_of(j)
                if a != b:
                    region[b] = a
        pieces = collections.defaultdict(list)
        for i in range(n):
            pieces[region_of(i)].append(i)
        for members_of in pieces.values():
            if len(members_of) >= min_component and all(room[i] < 0 for i in members_of):
                for i in members_of:
                    room[i] = rooms[0]
                rooms[0] += 1
    # Flood fill: the frontier edge of largest clearance first, ties in push order.
    heap, sequence = [], 0
    for i in range(n):
        if room[i] >= 0:
            for c, j in adjacency[i]:
                if room[j] < 0:
                    heapq.heappush(heap, (-c, sequence, j, room[i]))
                    sequence += 1
    while heap:
        _, _, j, r = heapq.heappop(heap)
        if room[j] >= 0:
            continue
        room[j] = r
        for c, k in adjacency[j]:
            if room[k] < 0:
                heapq.heappush(heap, (-c, sequence, k, r))
                sequence += 1
    return {ids[i]: room[i] for i in range(n)}


def extend_clearance(places, edges, saturation_m):
    """Per place id: its clearance plus, when it is at least saturation_m, its horizontal graph distance to the
    nearest place below saturation_m (multi-source Dijkstra over all edges; none when unreachable), as
    RoomFinder::compute_extent."""
    adjacency = collections.defaultdict(list)
    for a, b, _ in edges:
        length = math.hypot(places[a]["x"] - places[b]["x"], places[a]["y"] - places[b]["y"])
        adjacency[a].append((b, length))
        adjacency[b].append((a, length))
    depth = {p: (0.0 if a["d"] < saturation_m else math.inf) for p, a in places.items()}
    heap = [(0.0, p) for p, d in depth.items() if d == 0.0]
    heapq.heapify(heap)
    while heap:
        d, p = heapq.heappop(heap)
        if d > depth[p]:
            continue
        for q, length in adjacency[p]:
            if d + length < depth[q]:
                depth[q] = d + length
                heapq.heappush(heap, (depth[q], q))
    return {p: a["d"] + (depth[p] if depth[p] != math.inf else 0.0) for p, a in places.items()}


def split_by_extent(places, edges, room_of, saturation_m, min_extent_m, max_extent_m, min_persistence_m,
                    min_component):
    """RoomFinder's extent split: every room seeded again on the extended clearance through its own edges; a room
    with two or more seeds is split and its other places filled among them, through its own edges."""
    extent = extend_clearance(places, edges, saturation_m)
    by_room = collections.defaultdict(list)
    for p, r in room_of.items():
        if r is not None and r >= 0:
            by_room[r].append(p)
    out = dict(room_of)
    next_room = max([r for r in room_of.values() if r is not None] + [0]) + 1
    for r, members in by_room.items():
        inside = set(members)
        sub = {p: dict(places[p], d=extent[p]) for p in members}
        sub_edges = [(a, b, -1.0) for a, b, _ in edges if a in inside and b in inside]
        parts = find_rooms(sub, sub_edges, min_component, min_persistence_m, min_extent_m, max_extent_m)
        labels = sorted(set(v for v in parts.values() if v >= 0))
        if len(labels) < 2:
            continue
        new_room = {labels[0]: r}
        for v in labels[1:]:
            new_room[v] = next_room
            next_room += 1
        for p in members:
            if parts[p] >= 0:
                out[p] = new_room[parts[p]]
    return out


def merge_corridors(places, edges, room_of, min_neighbours, min_open_edges):
    """RoomFinder's corridor merge: while two adjacent rooms both touch at least min_neighbours rooms (through any
    place edge; a closed one has weight <= 0) and meet through at least min_open_edges open edges, the pair with
    the most open edges (ties: the lower pair of rooms) becomes one room (the lower keeps its number)."""
    room = dict(room_of)
    while True:
        neighbours, opened = collections.defaultdict(set), collections.Counter()
        for a, b, w in edges:
            ra, rb = room[a], room[b]
            if ra is None or rb is None or ra < 0 or rb < 0 or ra == rb:
                continue
            neighbours[ra].add(rb)
            neighbours[rb].add(ra)
            opened[(min(ra, rb), max(ra, rb))] += 1 if w > 0 else 0
        best = None
        for pair in sorted(opened):
            n = opened[pair]
            if (n >= min_open_edges and (best is None or n > opened[best]) and
                    min(len(neighbours[pair[0]]), len(neighbours[pair[1]])) >= min_neighbours):
                best = pair
        if best is None:
            return room
        for p, r in room.items():
            if r == best[1]:
                room[p] = best[0]


def wall_sight(stem, places, z, doors):
    """rooms::WallSight's slice at z from the dump's surface (stem + ".surface.f32"), with the door stage's settings
    (the config's "doors" section): (structure mask [row, col], raster origin, cell side), or None without the
    surface. Needs numpy (python3-numpy)."""
    import numpy as np
    cell_m, half_band_m, place_band_m = doors["cell_m"], doors["slice_half_band_m"], doors["place_band_m"]
    min_wall_height_m, mapped_radius_m = doors["min_wall_height_m"], doors["mapped_radius_m"]
    dilation_m, min_wall_m = doors["sight_wall_dilation_m"], doors["sight_min_wall_m"]
    furniture_max_m, furniture_min_width_m = doors["sight_furniture_max_m"], doors["sight_furniture_min_width_m"]
    path = stem + ".surface.f32"
    if not os.path.exists(path):
        return None
    v = np.fromfile(path, dtype=np.float32).reshape(-1, 3).astype(np.float64)
    v = v[np.abs(v[:, 2] - z) <= half_band_m]
    xy = np.array([(a["x"], a["y"]) for a in places.values() if abs(a["z"] - z) <= place_band_m])
    if len(v) == 0 or len(xy) == 0:
        return None
    margin = mapped_radius_m + 2 * cell_m
    lo = xy.min(0) - margin
    cols, rows = (np.ceil((xy.max(0) + margin - lo) / cell_m)).astype(int)
    c = np.floor((v[:, :2] - lo) / cell_m).astype(np.int64)
    inside = (c[:, 0] >= 0) & (c[:, 1] >= 0) & (c[:, 0] < cols) & (c[:, 1] < rows)
    c, vz = c[inside], v[inside, 2]
    idx = c[:, 1] * cols + c[:, 0]
    zmin, zmax = np.full(rows * cols, np.inf), np.full(rows * cols, -np.inf)
    np.minimum.at(zmin, idx, vz)
    np.maximum.at(zmax, idx, vz)
    grown = ((zmax - zmin) >= min_wall_height_m).reshape(rows, cols)
    for _ in range(int(round(dilation_m / cell_m))):
        g = grown.copy()
        g[1:, :] |= grown[:-1, :]
        g[:-1, :] |= grown[1:, :]
        g[:, 1:] |= grown[:, :-1]
        g[:, :-1] |= grown[:, 1:]
        grown = g
    mask = np.zeros_like(grown)
    seen = np.zeros_like(grown)
    for r0, c0 in zip(*np.nonzero(grown)):
        if seen[r0, c0]:
            continue
        seen[r0, c0] = True
        stack, cells = [(r0, c0)], []
        while stack:
            r, q = stack.pop()
            cells.append((r, q))
            for dr in (-1, 0, 1):
                for dq in (-1, 0, 1):
                    rr, qq = r + dr, q + dq
                    if 0 <= rr < rows and 0 <= qq < cols and grown[rr, qq] and not seen[rr, qq]:
                        seen[rr, qq] = True
                        stack.append((rr, qq))
        a = np.array(cells)
        diagonal = math.hypot(a[:, 0].max() - a[:, 0].min() + 1, a[:, 1].max() - a[:, 1].min() + 1)
        island = diagonal < furniture_max_m / cell_m and len(cells) / diagonal > furniture_min_width_m / cell_m
        if diagonal >= min_wall_m / cell_m and not island:
            mask[a[:, 0], a[:, 1]] = True
    return mask, lo, cell_m


def sees(sight, a, b):
    """WallSight::sees on one slice: the plan segment a-b crosses no structure cell (cells in order, as the C++)."""
    mask, lo, cell_m = sight
    rows, cols = mask.shape
    x0, y0 = (a[0] - lo[0]) / cell_m, (a[1] - lo[1]) / cell_m
    x1, y1 = (b[0] - lo[0]) / cell_m, (b[1] - lo[1]) / cell_m
    c, r, ce, re = math.floor(x0), math.floor(y0), math.floor(x1), math.floor(y1)
    dx, dy = x1 - x0, y1 - y0
    sc, sr = (1 if dx > 0 else -1), (1 if dy > 0 else -1)
    tdc = abs(1 / dx) if dx else math.inf
    tdr = abs(1 / dy) if dy else math.inf
    tc = (math.floor(x0) + 1 - x0) * tdc if dx > 0 else ((x0 - math.floor(x0)) * tdc if dx < 0 else math.inf)
    tr = (math.floor(y0) + 1 - y0) * tdr if dy > 0 else ((y0 - math.floor(y0)) * tdr if dy < 0 else math.inf)
    for _ in range(abs(ce - c) + abs(re - r) + 1):
        if 0 <= c < cols and 0 <= r < rows and mask[r, c]:
            return False
        if tc < tr:
            c, tc = c + sc, tc + tdc
        else:
            r, tr = r + sr, tr + tdr
    return True


def touching_pairs(places, room_of, sight, max_clearance_m):
    """RoomFinder::find_touching_pairs: pairs of places in different rooms whose free-space spheres touch (distance
    below the sum of their clearances, each at most max_clearance_m) and that see each other."""
    radius = {p: min(a["d"], max_clearance_m) for p, a in places.items()}
    usable = [p for p in sorted(places) if room_of[p] is not None and room_of[p] >= 0 and radius[p] > 0]
    if not usable:
        return []
    cell = 2 * max(radius[p] for p in usable)
    grid = collections.defaultdict(list)
    for p in usable:
        grid[(math.floor(places[p]["x"] / cell), math.floor(places[p]["y"] / cell))].append(p)
    pairs = []
    for p in usable:
        a = places[p]
        gx, gy = math.floor(a["x"] / cell), math.floor(a["y"] / cell)
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for q in grid.get((gx + dx, gy + dy), ()):
                    if q <= p or room_of[q] == room_of[p]:
                        continue
                    b = places[q]
                    d2 = (a["x"] - b["x"]) ** 2 + (a["y"] - b["y"]) ** 2 + (a["z"] - b["z"]) ** 2
                    if d2 < (radius[p] + radius[q]) ** 2 and sees(sight, (a["x"], a["y"]), (b["x"], b["y"])):
                        pairs.append((p, q, -2.0))
    return pairs


def merge_visible(places, edges, room_of, sight, min_share, samples, max_rounds, local_radius_m, local_min_share,
                  local_min_places, touching, touch_max_clearance_m):
    """RoomFinder's visibility merge on one slice: each round, up to `samples` places per room (ranks
    floor(j (n - 1) / (samples - 1)) in id order), each adjacent pair's share of clear sight lines, then the pairs at
    or above min_share clearest first (ties: the lower pair), each room once a round (the lower keeps its number).
    A pair short of it is tested again on its places within local_radius_m of the other room's ends of the edges
    between them (at least local_min_places a side, local_min_share), and merges after the whole-room pairs.
    With touching, the touching_pairs found before the rounds count as edges between rooms too."""
    room = dict(room_of)
    ids = sorted(places)
    if touching:
        edges = list(edges) + touching_pairs(places, room, sight, touch_max_clearance_m)

    def pick(ps):
        n = len(ps)
        return ps if n <= samples else [ps[j * (n - 1) // (samples - 1)] for j in range(samples)]

    def share_of(pa, pb):
        clear = sum(sees(sight, (places[p]["x"], places[p]["y"]), (places[q]["x"], places[q]["y"]))
                    for p in pa for q in pb)
        return clear * 65535 // (len(pa) * len(pb))

    def near(ps, ends):
        r2 = local_radius_m * local_radius_m
        return [p for p in ps if any((places[p]["x"] - places[q]["x"]) ** 2 + (places[p]["y"] - places[q]["y"]) ** 2
                                     <= r2 for q in ends)]

    for _ in range(max_rounds):
        members = collections.defaultdict(list)
        for p in ids:
            if room[p] is not None and room[p] >= 0:
                members[room[p]].append(p)
        picked = {r: pick(ps) for r, ps in members.items()}
        pairs = collections.defaultdict(lambda: (set(), set()))  # (lower, higher) -> (lower's ends, higher's ends)
        for a, b, _ in edges:
            ra, rb = room[a], room[b]
            if ra is not None and rb is not None and ra >= 0 and rb >= 0 and ra != rb:
                if ra > rb:
                    a, b, ra, rb = b, a, rb, ra
                pairs[(ra, rb)][0].add(a)
                pairs[(ra, rb)][1].add(b)
        cands = []
        for (ra, rb), (ends_a, ends_b) in sorted(pairs.items()):
            share = share_of(picked[ra], picked[rb])
            if share >= math.ceil(min_share * 65535):
                cands.append((-(0x8000 | share >> 1), ra, rb))
            elif local_radius_m > 0:
                na, nb = near(members[ra], ends_b), near(members[rb], ends_a)
                if len(na) >= local_min_places and len(nb) >= local_min_places:
                    share = share_of(pick(na), pick(nb))
                    if share > 0 and share >= math.ceil(local_min_share * 65535):
                        cands.append((-max(1, share >> 1), ra, rb))
        if not cands:
            break
        done = set()
        for _, ra, rb in sorted(cands):
            if ra in done or rb in done:
                continue
            done.update((ra, rb))
            for p in members[rb]:
                room[p] = ra
    return room


def score(places, room_of):
    """(sum of precisions, estimated rooms, sum of recalls, ground-truth rooms, overlapping places, places)."""
    estimated = collections.defaultdict(collections.Counter)
    truth = collections.defaultdict(collections.Counter)
    for p, a in places.items():
        if a["truth"] <= 0:
            continue
        r = room_of[p] if room_of[p] is not None and room_of[p] >= 0 else ("none", p)
        estimated[r][a["truth"]] += 1
        truth[a["truth"]][r] += 1
    overlap = sum(max(c.values()) for c in estimated.values())
    return (sum(max(c.values()) / sum(c.values()) for c in estimated.values()), len(estimated),
            sum(max(c.values()) / sum(c.values()) for c in truth.values()), len(truth), overlap,
            sum(sum(c.values()) for c in estimated.values()))


def pooled(scores):
    s = [sum(x[i] for x in scores) for i in range(6)]
    return s[0] / max(1, s[1]), s[2] / max(1, s[3]), s[4] / max(1, s[5]), s[1]


def load_config(path):
    """The "rooms" and "doors" sections of an app config in `qsg_app --dump-config`'s form (whole-line // comments;
    "inf" for an unbounded real)."""
    with open(path) as f:
        config = json.loads("".join(line for line in f if not line.lstrip().startswith("//")))
    return {name: {k: (float(v) if v in ("inf", "-inf") else v) for k, v in config.get(name, {}).items()}
            for name in ("rooms", "doors")}


def set_setting(config, assignment):
    """rooms_eval's --set SECTION.KEY=VALUE on the loaded sections: the key must exist, the value of its kind."""
    path, eq, text = assignment.partition("=")
    section, dot, key = path.partition(".")
    if not eq or not dot or key not in config.get(section, {}):
        raise SystemExit("--set %s: expected rooms.KEY=VALUE or doors.KEY=VALUE with a key of the config" % assignment)
    old = config[section][key]
    try:
        if isinstance(old, bool):
            value = {"true": True, "1": True, "false": False, "0": False}[text]
        elif isinstance(old, (int, float)):
            value = int(text) if isinstance(old, int) and text.lstrip("-").isdigit() else float(text)
        else:
            value = text
    except (KeyError, ValueError):
        raise SystemExit("--set %s: expected a value like %r" % (assignment, old))
    config[section][key] = value


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dump_dir")
    ap.add_argument("--config", default=DEFAULT_CONFIG,
                    help="an app config in qsg_app --dump-config's form (default: firmware_app/config/default.json)")
    ap.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                    help="one room-finder (rooms.*) or door-stage (doors.*) setting, repeatable")
    ap.add_argument("--door-oracle-m", type=float, default=None, metavar="C",
                    help="a perfect door detector: every place edge between two ground-truth rooms gets clearance C "
                         "(0: cut), what any door or opening cue could give the persistence seeding at best")
    args = ap.parse_args()
    config = load_config(args.config)
    for assignment in args.set:
        set_setting(config, assignment)
    rc, doors = config["rooms"], config["doors"]
    if rc["seeding"] != "persistence" or rc["max_door_clearance_m"] != math.inf:
        raise SystemExit("the mirror has rooms.seeding=persistence with rooms.max_door_clearance_m=inf only")
    for variant in ("plain", "furnished"):
        files = sorted(glob.glob(os.path.join(args.dump_dir, "*_%s.txt" % variant)))
        if not files:
            continue
        cpp, mirror = [], []
        for path in files:
            places, edges = load(path)
            cpp.append(score(places, {p: (a["room"] if a["room"] != 0 else -1) for p, a in places.items()}))
            if args.door_oracle_m is not None:
                edges = [(a, b, args.door_oracle_m if 0 < places[a]["truth"] != places[b]["truth"] > 0 else w)
                         for a, b, w in edges]
            rooms = find_rooms(places, edges, rc["min_component_size"], rc["min_persistence_m"], rc["min_dilation_m"],
                               rc["max_dilation_m"], rc["seed_closed_regions"])
            if rc["split_by_extent"]:
                rooms = split_by_extent(places, edges, rooms, rc["extent_saturation_m"], rc["split_min_extent_m"],
                                        rc["split_max_extent_m"], rc["split_min_persistence_m"],
                                        rc["split_min_component_size"])
            if rc["merge_corridors"]:
                rooms = merge_corridors(places, edges, rooms, rc["corridor_min_neighbours"],
                                        rc["corridor_min_open_edges"])
            if rc["merge_visible"]:
                with open(path) as f:
                    door_z = [float(line.split()[5]) for line in f if line.startswith("D ")]
                sight = wall_sight(path[:-4], places, door_z[0] if door_z else 1.2, doors)
                if sight is not None:
                    rooms = merge_visible(places, edges, rooms, sight, rc["visible_min_share"], rc["visible_samples"],
                                          rc["visible_max_rounds"], rc["visible_local_radius_m"],
                                          rc["visible_local_min_share"], rc["visible_local_min_places"],
                                          rc["visible_touching"], rc["visible_touch_max_clearance_m"])
            mirror.append(score(places, rooms))
        for name, s in (("C++ (dump)", cpp), ("mirror", mirror)):
            print("%-10s %-10s places: P %.3f R %.3f | P weighted %.3f | rooms %d" % ((variant, name) + pooled(s)))


if __name__ == "__main__":
    main()
