#!/usr/bin/python3
"""Sandbox for room-finder ideas: a Python mirror of core/rooms' persistence seeding, closed-off regions, flood fill,
extent split and corridor merge, run on the places that `rooms_eval --dump-places DIR` wrote, scored per place
against the ground-truth rooms.

    build/release/bench/rooms/rooms_eval --cache-dir C --generated 0 --dump-places D   # once (cached: seconds)
    /usr/bin/python3 bench/rooms/finder_sandbox.py D [--min-persistence-m P] [--min-component N] [--no-extent-split]
        [--no-corridor-merge] [--corridor-min-neighbours N] [--corridor-min-open-edges N]

It prints, per variant (plain, furnished), the same place-level score for the C++ rooms of the dump and for this
mirror, so a change tried here first can be judged in well under a second before it is written in C++. The mirror
follows the C++ closely, not exactly (ties among equal clearances fall in the dump's order, not the ids'): on
session 16's graphs, plain, 149 rooms against the C++ 150 with the corridor merge off, the same 136 with it on on
session 17's. Compare a change against the mirror's own baseline. The score is a proxy of rooms_eval's: it
counts places, not free cells (max-overlap precision per estimated room and recall per ground-truth room, means over
rooms, and the precision weighted by places); places outside every ground-truth room are left out, and a place
without a room counts as a room of its own. The real figures stay rooms_eval's.
"""
import argparse
import collections
import glob
import heapq
import math
import os


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


def find_rooms(places, edges, min_component=6, min_persistence_m=0.4, d_min=0.5, d_max=1.2):
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
    if any(c < 0 for c, _, _ in edge_list):
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


def split_by_extent(places, edges, room_of, saturation_m=1.0, min_extent_m=1.0, max_extent_m=2.5,
                    min_persistence_m=0.5, min_component=6):
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


def merge_corridors(places, edges, room_of, min_neighbours=3, min_open_edges=20):
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


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dump_dir")
    ap.add_argument("--min-persistence-m", type=float, default=0.4)
    ap.add_argument("--min-component", type=int, default=6)
    ap.add_argument("--no-extent-split", action="store_true", help="the room finder without its extent split")
    ap.add_argument("--extent-saturation-m", type=float, default=1.0)
    ap.add_argument("--split-min-extent-m", type=float, default=1.0)
    ap.add_argument("--split-max-extent-m", type=float, default=2.5)
    ap.add_argument("--split-min-persistence-m", type=float, default=0.5)
    ap.add_argument("--split-min-component", type=int, default=6)
    ap.add_argument("--no-corridor-merge", action="store_true", help="the room finder without its corridor merge")
    ap.add_argument("--corridor-min-neighbours", type=int, default=3)
    ap.add_argument("--corridor-min-open-edges", type=int, default=20)
    ap.add_argument("--door-oracle-m", type=float, default=None, metavar="C",
                    help="a perfect door detector: every place edge between two ground-truth rooms gets clearance C "
                         "(0: cut), what any door or opening cue could give the persistence seeding at best")
    args = ap.parse_args()
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
            rooms = find_rooms(places, edges, args.min_component, args.min_persistence_m)
            if not args.no_extent_split:
                rooms = split_by_extent(places, edges, rooms, args.extent_saturation_m, args.split_min_extent_m,
                                        args.split_max_extent_m, args.split_min_persistence_m,
                                        args.split_min_component)
            if not args.no_corridor_merge:
                rooms = merge_corridors(places, edges, rooms, args.corridor_min_neighbours,
                                        args.corridor_min_open_edges)
            mirror.append(score(places, rooms))
        for name, s in (("C++ (dump)", cpp), ("mirror", mirror)):
            print("%-10s %-10s places: P %.3f R %.3f | P weighted %.3f | rooms %d" % ((variant, name) + pooled(s)))


if __name__ == "__main__":
    main()
