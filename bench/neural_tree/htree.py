"""H-tree construction for the neural tree, mirrored line by line in core/neural_tree/h_tree.cc (parity)."""

# Node layers of the object-room-building graph (the paper's hierarchical graph, bottom to top).
LAYER_OBJECT = 1
LAYER_ROOM = 2
LAYER_BUILDING = 3

# H-tree node types; the network sees them one-hot.
TYPE_LEAF_OBJECT = 0
TYPE_LEAF_ROOM = 1
TYPE_LEAF_BUILDING = 2
TYPE_BAG_OBJECTS = 3       # objects only
TYPE_BAG_ROOM_OBJECTS = 4  # exactly one room plus objects
TYPE_BAG_ROOMS = 5         # rooms (and possibly the building), or any other mix
NUM_TYPES = 6


class Graph:
    """Undirected hierarchical graph: layer per node, adjacency sets."""

    def __init__(self, layers, edges):
        self.layers = list(layers)
        self.adj = [set() for _ in layers]
        for a, b in edges:
            if a != b:
                self.adj[a].add(b)
                self.adj[b].add(a)

    def edges(self):
        return sorted((a, b) for a in range(len(self.layers)) for b in self.adj[a] if a < b)


def tree_decomposition(graph, vertices):
    """Min-degree elimination (ties: smallest id) on graph[vertices]; root bag first.

    Returns (bags, edges): bags are sorted vertex lists, edges are (parent, child) bag indices.
    """
    vertices = sorted(vertices)
    if not vertices:
        return [], []
    vset = set(vertices)
    work = {v: set(u for u in graph.adj[v] if u in vset) for v in vertices}
    order = []
    bag_of = {}
    elim_neighbours = {}
    while work:
        v = min(work, key=lambda x: (len(work[x]), x))
        nbrs = sorted(work[v])
        for a in nbrs:
            work[a].discard(v)
            for b in nbrs:
                if a != b:
                    work[a].add(b)
        del work[v]
        bag_of[v] = sorted([v] + nbrs)
        elim_neighbours[v] = nbrs
        order.append(v)
    position = {v: i for i, v in enumerate(order)}
    parent = {}
    roots = []
    for v in order:
        if elim_neighbours[v]:
            parent[v] = min(elim_neighbours[v], key=lambda u: position[u])
        else:
            parent[v] = None
            roots.append(v)
    # Disconnected components: hang every other root under the last one (they share no vertex, so it stays valid).
    top = roots[-1]
    for r in roots[:-1]:
        parent[r] = top
    # Contract a parent bag into a child that contains it (top-down), so no bag is a subset of a neighbour's.
    alive = {v: True for v in order}
    for u in reversed(order):
        if not alive[u]:
            continue
        children = [c for c in order if alive[c] and parent[c] == u]
        sup = None
        for c in children:
            if set(bag_of[u]) <= set(bag_of[c]):
                sup = c
                break
        if sup is None:
            continue
        parent[sup] = parent[u]
        for c in children:
            if c != sup:
                parent[c] = sup
        alive[u] = False
    kept = [v for v in reversed(order) if alive[v]]  # root first
    index = {v: i for i, v in enumerate(kept)}
    bags = [bag_of[v] for v in kept]
    edges = []
    for v in kept:
        if parent[v] is not None:
            edges.append((index[parent[v]], index[v]))
    return bags, edges


def hierarchical_tree_decomposition(graph, vertices):
    """The paper's Algorithm 1 on graph[vertices]: top layer decomposed, then each node's children glued below."""
    vertices = sorted(vertices)
    vset = set(vertices)
    top_layer = max(graph.layers[v] for v in vertices)
    bags, edges = tree_decomposition(graph, [v for v in vertices if graph.layers[v] == top_layer])
    for layer in range(top_layer, LAYER_OBJECT, -1):
        for v in vertices:
            if graph.layers[v] != layer:
                continue
            children = sorted(u for u in graph.adj[v] if u in vset and graph.layers[u] == layer - 1)
            if not children:
                continue
            sub_bags, sub_edges = tree_decomposition(graph, children)
            attach = next(i for i, b in enumerate(bags) if v in b)
            offset = len(bags)
            bags.extend(sorted(b + [v]) for b in sub_bags)
            edges.extend((offset + a, offset + b) for a, b in sub_edges)
            edges.append((attach, offset))
    return bags, edges


def connected(nodes, edges):
    """True when the nodes (a non-empty list) are connected through the edges among them (undirected)."""
    inside = set(nodes)
    adj = {x: [] for x in inside}
    for a, b in edges:
        if a in inside and b in inside:
            adj[a].append(b)
            adj[b].append(a)
    seen = {nodes[0]}
    stack = [nodes[0]]
    while stack:
        x = stack.pop()
        for y in adj[x]:
            if y not in seen:
                seen.add(y)
                stack.append(y)
    return len(seen) == len(inside)


def check_tree_decomposition(graph, vertices, bags, edges):
    """Returns '' when (bags, edges) is a tree and a tree decomposition of graph[vertices], else the reason."""
    n = len(bags)
    if n == 0:
        return "" if not vertices else "no bags"
    if len(edges) != n - 1:
        return "not a tree: %d bags, %d edges" % (n, len(edges))
    if not connected(list(range(n)), edges):
        return "not a tree: disconnected"
    vset = set(vertices)
    for v in vertices:
        holding = [i for i in range(n) if v in bags[i]]
        if not holding:
            return "vertex %d in no bag" % v
        if not connected(holding, edges):
            return "bags of vertex %d not connected" % v
    for a in vertices:
        for b in graph.adj[a]:
            if b in vset and a < b and not any(a in bag and b in bag for bag in bags):
                return "edge (%d,%d) in no bag" % (a, b)
    for bag in bags:
        if not set(bag) <= vset:
            return "bag holds a foreign vertex"
    return ""


class HTree:
    """Nodes (members, type), undirected tree edges, and for each leaf the graph node it stands for."""

    def __init__(self):
        self.members = []
        self.types = []
        self.edges = []
        self.width = 0  # treewidth of the top-level decomposition (largest bag - 1)

    def add(self, graph, members):
        self.members.append(list(members))
        self.types.append(node_type(graph, members))
        return len(self.members) - 1


def node_type(graph, members):
    if len(members) == 1:
        layer = graph.layers[members[0]]
        return {LAYER_OBJECT: TYPE_LEAF_OBJECT, LAYER_ROOM: TYPE_LEAF_ROOM}.get(layer, TYPE_LEAF_BUILDING)
    rooms = sum(1 for m in members if graph.layers[m] == LAYER_ROOM)
    objects = sum(1 for m in members if graph.layers[m] == LAYER_OBJECT)
    if objects == len(members):
        return TYPE_BAG_OBJECTS
    if rooms == 1 and objects == len(members) - 1:
        return TYPE_BAG_ROOM_OBJECTS
    return TYPE_BAG_ROOMS


def is_complete(graph, members):
    return all(b in graph.adj[a] for i, a in enumerate(members) for b in members[i + 1:])


def build_htree(graph):
    """Algorithm 1 decomposition, then every bag split until the leaves are single graph nodes. Every tree built is
    checked (a tree, a tree decomposition, leaves covering the graph); ValueError names what failed."""
    h = HTree()
    vertices = list(range(len(graph.layers)))
    if not vertices:
        return h
    bags, edges = hierarchical_tree_decomposition(graph, vertices)
    why = check_tree_decomposition(graph, vertices, bags, edges)
    if why:
        raise ValueError("hierarchical tree decomposition: " + why)
    h.width = max(len(b) for b in bags) - 1
    base = len(h.members)
    for b in bags:
        h.add(graph, b)
    h.edges.extend((base + a, base + b) for a, b in edges)
    # Breadth-first over bag nodes so node numbering is the same in C++.
    queue = list(range(base, base + len(bags)))
    head = 0
    while head < len(queue):
        node = queue[head]
        head += 1
        members = h.members[node]
        if len(members) == 1:
            continue
        sub_bags = None
        if not is_complete(graph, members):
            sub_bags, sub_edges = hierarchical_tree_decomposition(graph, members)
            if max(len(b) for b in sub_bags) >= len(members):
                sub_bags = None  # no progress: split into leaves instead
        if sub_bags is None:
            for m in members:
                leaf = h.add(graph, [m])
                h.edges.append((node, leaf))
            continue
        sub_base = len(h.members)
        for b in sub_bags:
            h.add(graph, b)
        h.edges.extend((sub_base + a, sub_base + b) for a, b in sub_edges)
        h.edges.append((node, sub_base))
        queue.extend(range(sub_base, sub_base + len(sub_bags)))
    why = check_htree(graph, h)
    if why:
        raise ValueError(why)
    return h


def check_htree(graph, h):
    """'' when the H-tree is a tree whose leaves cover every graph node, else the reason."""
    n = len(h.members)
    if len(h.edges) != n - 1:
        return "H-tree not a tree: %d nodes, %d edges" % (n, len(h.edges))
    if not connected(list(range(n)), h.edges):
        return "H-tree disconnected"
    covered = set(h.members[i][0] for i in range(n) if len(h.members[i]) == 1)
    if covered != set(range(len(graph.layers))):
        return "H-tree leaves miss a graph node"
    return ""
