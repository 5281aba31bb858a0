#!/usr/bin/python3
"""Offline training and evaluation of the room classifier (core/neural_tree) on Stanford3DSG rooms.

The classifier is a neural tree (GraphSAGE-style message passing on the H-tree of the object-room graph, an ensemble
of CONFIG['ensemble'] networks) whose class probabilities are averaged with those of a logistic-regression head on
the room's log object counts, box and furniture footprints (lr_features; the footprint of its largest bed, table,
sofa, ... by name, LR_FOOTPRINT_CLASSES): p = (1 - a) p_tree + a p_lr with a = lr_blend x the share of
the room's objects the LR can count (blend_log: a weighted geometric mean instead). The two are complementary: the
blend beats either alone under the same CV. cv also runs the issue's baseline, the LR on counts and box alone.
Every Stanford object is in the LR's vocabulary (share 1); the share matters for the pipeline's mpcat40 objects
(appliances, cabinet, shelving, ...), which the LR cannot see but the neural tree reads through their word vectors.

Commands (from the repository root, Debian's python3-torch; fixed seeds, one thread):
  /usr/bin/python3 bench/neural_tree/train_neural_tree.py cv        # 5x repeated stratified 5-fold CV: the neural
      tree alone, the LR baseline (counts and box), the LR head and the blend, mean +- std over repeats (about 11
      min on one core)
      (--jobs 2: folds in two processes, same figures; --seed-base: other fold splits, for tuning, e.g. 2001;
      --sweep: accuracy over LR l2, blend weight and mode and ensemble size; --oof FILE: the out-of-fold
      probabilities. Tune on a tuning split, never on the reported default one.)
  /usr/bin/python3 bench/neural_tree/train_neural_tree.py folds --out DIR   # the cv's fold models as weights files
      and folds.json (held-out rooms per file), for labels_eval --cv-weights DIR (same splits and seeds as cv)
  /usr/bin/python3 bench/neural_tree/train_neural_tree.py ssl       # the paper's 70/10/20 node-classification protocol
  /usr/bin/python3 bench/neural_tree/train_neural_tree.py train     # all rooms -> weights file (version 4: neural tree
      + LR head with its footprint classes + blend weight + the VIEWS' heads) + parity fixture (neural tree, LR and
      blended probabilities, and per view head its features, probabilities and blend)
  /usr/bin/python3 bench/neural_tree/train_neural_tree.py add-views --weights FILE | --folds DIR --out DIR2
      # rewrites weights files as version 4 with the VIEWS' heads, the rest unchanged (seconds; the same bytes as
      train or folds, whose neural tree training is deterministic)
  /usr/bin/python3 bench/neural_tree/train_neural_tree.py view-ceiling --json FILE   # LR, MLP, kNN on the rooms as
      the segmentation view shows them, same CV: what that view allows any model (a few minutes)
Any CONFIG entry can be overridden with --set key=value. Switches that need no C++ change: label_smoothing (of the
neural tree's cross-entropy; 0.05 chosen on the tuning splits), class_weight (loss weights count^-x), val_folds
(training length from an inner split of the training rooms), word_onehot and word_scale (what the word table holds), swa
(weights averaged over that last fraction of the epochs), lr_l2 (the LR head's L2), lr_blend and blend_log (the blend;
both travel in the weights file), lr_footprints (0: the LR head without the footprints; the file then lists no footprint
class), view_lr_l2 and view_lr_blend (the view heads'). cv-only ablations: box_relative, plain_graph, room_word_counts.
"""
import argparse
import base64
import json
import math
import os
import struct
import subprocess
import sys
import time

import numpy as np
import torch

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import htree as ht  # noqa: E402

REPO = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
DATA = os.environ.get("QSG_SHARED_DATA", os.path.join(REPO, "..", "shared", "data"))
ROOMS_JSON = os.path.join(DATA, "scene_graphs", "Stanford3DSG_rooms.json")
WORDS_JSON = os.path.join(DATA, "words", "glove100_scene_label_subset.json")
WEIGHTS_VERSION = 4  # 4: also view heads (VIEWS); 3: the LR head also reads furniture footprints; 2: the neural tree
# plus the LR head it is blended with (counts and box); 1: the neural tree alone
WEIGHTS_OUT = os.path.join(REPO, "core", "neural_tree", "weights", "room_classifier_v%d.json" % WEIGHTS_VERSION)
FIXTURE_OUT = os.path.join(REPO, "tests", "neural_tree", "parity_fixture.json")

GLOVE_DIM = 100


def set_layout(word_dim, room_words_dim=0):
    """Input feature layout (kept in the weights file; core/neural_tree reads offsets and word_dim from there)."""
    global WORD_DIM, OFF_TYPE, OFF_WORD, OFF_OBJ_SIZE, OFF_OBJ_REL, OFF_ROOM_SIZE, OFF_ROOM_COUNT
    global OFF_OBJ_LABEL_COUNT, OFF_ROOM_WORDS, ROOM_WORDS_DIM, INPUT_DIM
    WORD_DIM = word_dim
    ROOM_WORDS_DIM = room_words_dim
    OFF_TYPE = 0
    OFF_WORD = OFF_TYPE + ht.NUM_TYPES
    OFF_OBJ_SIZE = OFF_WORD + WORD_DIM
    OFF_OBJ_REL = OFF_OBJ_SIZE + 3
    OFF_ROOM_SIZE = OFF_OBJ_REL + 3
    OFF_ROOM_COUNT = OFF_ROOM_SIZE + 3
    OFF_OBJ_LABEL_COUNT = OFF_ROOM_COUNT + 1  # log(1 + objects of the same label in the room)
    # Room leaves: log(1 + objects of each word-table row r < ROOM_WORDS_DIM in the room), the counts LR sees.
    OFF_ROOM_WORDS = OFF_OBJ_LABEL_COUNT + 1
    INPUT_DIM = OFF_ROOM_WORDS + ROOM_WORDS_DIM


set_layout(GLOVE_DIM)
MIN_SIZE_M = 0.01  # floor under box sizes before the log

# Stanford3DSG room classes -> the paper's room labels (core/semantics/labels.h names).
ROOM_LABEL_MAP = {
    "bathroom": "bathroom", "bedroom": "bedroom", "corridor": "hallway", "dining_room": "dining room",
    "home_office": "office", "kitchen": "kitchen", "living_room": "living room",
    "storage_room": "utility room", "utility_room": "utility room", "lobby": "lobby", "playroom": "game room",
    "staircase": "stairwell", "closet": "closet", "gym": "gym", "garage": "garage",
}
MPCAT40 = ["void", "wall", "floor", "chair", "door", "table", "picture", "cabinet", "cushion", "window", "sofa", "bed",
           "curtain", "chest_of_drawers", "plant", "sink", "stairs", "ceiling", "toilet", "stool", "towel", "mirror",
           "tv_monitor", "shower", "column", "bathtub", "counter", "fireplace", "lighting", "beam", "railing",
           "shelving", "blinds", "gym_equipment", "seating", "board_panel", "furniture", "appliances", "clothes",
           "objects", "misc", "unlabeled"]

# View heads (weights version 4). The app may perceive objects only through its segmentation network's classes: a
# room seen that way lacks every object outside the network's label set (no toilet, sink, bed or appliance for the
# PASCAL VOC network), and a model trained on fully labelled rooms reads each missing toilet as evidence that there is
# none. A view head is an LR head (the same features, restricted to the view's classes) trained on the training rooms
# as the view shows them, every object outside `reads` removed: it learns what the view's evidence (its few classes
# and the room box) says, rooms with nothing visible included. `reads`: the training classes the view's mpcat40
# labels are read as through core/neural_tree/label_map.h; the C++ classifier takes the view head whose reads are
# the largest subset of what RoomClassifier::Config::perceived_labels can show (tests/neural_tree/label_map_test.cc
# checks this list against the network's label map). Its blend weight (the neural tree gets 1 - it) and L2 are
# CONFIG's view_lr_blend and view_lr_l2, chosen on held-out data (bench/results/room_labels.md).
VIEWS = [{"name": "segmentation_pascal_voc", "label_map": "firmware_app/config/segmentation_pascal_voc.json",
          "reads": ["chair", "couch", "dining_table", "plant", "tv"]},
         {"name": "mpcat40", "label_map": "core/neural_tree/label_map.cc (every mpcat40 label)",
          "reads": ["chair", "couch", "dining_table", "plant", "tv", "bed", "sink", "toilet", "bench", "refrigerator",
                    "oven", "microwave"]}]
VIEW_LR_L2 = 3e-3  # best out-of-fold log-loss on both tuning splits (seed bases 2001, 3001), accuracy within 0.3 point of the best
VIEW_LR_BLEND = 1.0  # labels_eval --calibrate: the segmentation view is best with the view head alone (bench/results/room_labels.md)

CONFIG = dict(label_count=1, box_relative=0, plain_graph=0, agg_sum=0, ensemble=3, pos_scale=1.0, hidden=32, layers=3,
              lr=0.005, weight_decay=5e-4, dropout=0.25, epochs=250, lr_l2=1e-2, word_onehot=1, class_weight=0.0,
              val_folds=0, max_epochs=400, room_word_counts=0, word_scale=1.0, swa=0.0, lr_blend=0.6, blend_log=0,
              lr_footprints=1, label_smoothing=0.05, view_lr_l2=VIEW_LR_L2, view_lr_blend=VIEW_LR_BLEND)
SWEEP_LR_L2 = [1e-3, 3e-3, 1e-2, 3e-2, 1e-1, 3e-1]  # cv --sweep


# ----------------------------------------------------------------------------------------------------------------
# Data and features
def load_words():
    with open(WORDS_JSON) as f:
        return json.load(f)["vectors"]


def word_feature(words, name):
    """Mean of the word vectors of a (compound) label, L2-normalised; zeros when no word is known."""
    parts = [p for p in name.replace("-", "_").replace(" ", "_").split("_") if p]
    vecs = [np.asarray(words[p][:GLOVE_DIM], dtype=np.float64) for p in parts if p in words]
    if not vecs:
        return np.zeros(GLOVE_DIM, dtype=np.float32)
    v = np.mean(vecs, axis=0)
    return (v / max(np.linalg.norm(v), 1e-9)).astype(np.float32)


def word_table_for(words, names, object_names):
    """Rows of the model's word table: the GloVe vector, then (word_onehot) a one-hot over the training set's object
    classes, so the network can tell apart classes whose word vectors are close; other names get a zero one-hot."""
    glove = np.stack([word_feature(words, n) for n in names]) * np.float32(CONFIG["word_scale"])
    if not CONFIG["word_onehot"]:
        return glove
    onehot = np.zeros((len(names), len(object_names)), dtype=np.float32)
    for i, n in enumerate(names):
        if n in object_names:
            onehot[i, object_names.index(n)] = 1.0
    return np.concatenate([glove, onehot], axis=1)


def load_rooms():
    with open(ROOMS_JSON) as f:
        d = json.load(f)
    classes = sorted(d["room_labels"], key=lambda k: d["room_labels"][k])
    object_names = sorted(d["object_labels"], key=lambda k: d["object_labels"][k])
    return d["graphs"], classes, object_names


class SceneInput:
    """One object-room(-building) graph: per node layer, word-table index, centroid, size; undirected edges."""

    def __init__(self, layers, word, centroid, size, edges, parent_room):
        self.layers = layers
        self.word = word
        self.centroid = np.asarray(centroid, dtype=np.float64).reshape(-1, 3)
        self.size = np.asarray(size, dtype=np.float64).reshape(-1, 3)
        self.edges = edges
        self.parent_room = parent_room  # object -> its room's node index, else -1


def scene_from_stanford(g, word_index):
    layers, word, cen, size = [], [], [], []
    for n in g["nodes"]:
        layers.append(ht.LAYER_ROOM if n["type"] == "room" else ht.LAYER_OBJECT)
        word.append(word_index[n["label"]] if n["type"] != "room" else -1)
        cen.append(n["x"][:3])
        size.append(n["x"][3:6])
    # Undirected: the stored graph lists object->room only; keep each pair once.
    edges = sorted(set((min(a, b), max(a, b)) for a, b in g["edges"] if a != b))
    room = layers.index(ht.LAYER_ROOM)
    parent = [room if l == ht.LAYER_OBJECT else -1 for l in layers]
    return SceneInput(layers, word, cen, size, edges, parent)


def log_box(size):
    """Box size without the room's orientation: log of the larger and smaller horizontal side and the height."""
    sx, sy, sz = (max(float(v), MIN_SIZE_M) for v in size)
    return [math.log(max(sx, sy)), math.log(min(sx, sy)), math.log(sz)]


def offset_feature(d):
    """A relative position without the room's orientation: horizontal distance, height difference, distance."""
    h = math.hypot(d[0], d[1])
    return [h, d[2], math.sqrt(h * h + d[2] * d[2])]


def htree_features(scene, word_table):
    """H-tree, node features x, node positions and leaf->room pooling for one scene (same rules as C++)."""
    g = ht.Graph(scene.layers, scene.edges)
    if CONFIG["plain_graph"]:  # ablation: message passing on the input graph itself (a plain GNN)
        h = ht.HTree()
        for v in range(len(scene.layers)):
            h.add(g, [v])
        h.edges = g.edges()
    else:
        h = ht.build_htree(g)
    n = len(h.members)
    x = np.zeros((n, INPUT_DIM), dtype=np.float32)
    pos = np.zeros((n, 3), dtype=np.float64)
    counts = {}
    label_counts = {}
    for v, l in enumerate(scene.layers):
        if l == ht.LAYER_OBJECT and scene.parent_room[v] >= 0:
            counts[scene.parent_room[v]] = counts.get(scene.parent_room[v], 0) + 1
            key = (scene.parent_room[v], scene.word[v])
            label_counts[key] = label_counts.get(key, 0) + 1
    pool_node, pool_room = [], []
    for i, members in enumerate(h.members):
        x[i, OFF_TYPE + h.types[i]] = 1.0
        pos[i] = scene.centroid[members].mean(axis=0)
        if len(members) != 1:
            continue
        v = members[0]
        if scene.layers[v] == ht.LAYER_OBJECT:
            if scene.word[v] >= 0:
                x[i, OFF_WORD:OFF_WORD + WORD_DIM] = word_table[scene.word[v]]
            x[i, OFF_OBJ_SIZE:OFF_OBJ_SIZE + 3] = log_box(scene.size[v])
            r = scene.parent_room[v]
            if r >= 0 and CONFIG["label_count"]:
                x[i, OFF_OBJ_LABEL_COUNT] = math.log1p(label_counts[(r, scene.word[v])])
            if r >= 0 and CONFIG["box_relative"]:
                # Where in the room's box: |offset| over the half extent per axis (0 centre, 1 wall), height signed.
                half = np.maximum(scene.size[r], MIN_SIZE_M) / 2
                d = (scene.centroid[v] - scene.centroid[r]) / half
                x[i, OFF_OBJ_REL:OFF_OBJ_REL + 3] = [abs(d[0]), abs(d[1]), d[2]]
            elif r >= 0:
                x[i, OFF_OBJ_REL:OFF_OBJ_REL + 3] = offset_feature(scene.centroid[v] - scene.centroid[r])
        elif scene.layers[v] == ht.LAYER_ROOM:
            x[i, OFF_ROOM_SIZE:OFF_ROOM_SIZE + 3] = log_box(scene.size[v])
            x[i, OFF_ROOM_COUNT] = math.log1p(counts.get(v, 0))
            for (r, w), c in label_counts.items():
                if r == v and 0 <= w < ROOM_WORDS_DIM:
                    x[i, OFF_ROOM_WORDS + w] = math.log1p(c)
            pool_node.append(i)
            pool_room.append(v)
    # Mean relative position of each node's H-tree neighbours: the edge feature, the same for every layer.
    rel = np.zeros((n, 3), dtype=np.float64)
    deg = np.zeros(n, dtype=np.float64)
    for a, b in h.edges:
        rel[a] += offset_feature(pos[b] - pos[a])
        rel[b] += offset_feature(pos[a] - pos[b])
        deg[a] += 1
        deg[b] += 1
    rel /= np.maximum(deg, 1)[:, None]
    return h, x, rel.astype(np.float32), pool_node, pool_room


class Batch:
    """Disjoint union of H-trees as flat tensors."""

    def __init__(self, items):
        xs, rels, src, dst, pool_node, pool_seg = [], [], [], [], [], []
        offset = 0
        seg = 0
        self.room_of_seg = []
        for item_index, (h, x, rel, pnodes, prooms) in enumerate(items):
            xs.append(x)
            rels.append(rel)
            for a, b in h.edges:
                src += [offset + a, offset + b]
                dst += [offset + b, offset + a]
            # One pooling segment per room of the scene.
            for room in sorted(set(prooms)):
                for pn, pr in zip(pnodes, prooms):
                    if pr == room:
                        pool_node.append(offset + pn)
                        pool_seg.append(seg)
                self.room_of_seg.append((item_index, room))
                seg += 1
            offset += x.shape[0]
        self.x = torch.from_numpy(np.concatenate(xs))
        self.rel = torch.from_numpy(np.concatenate(rels))
        # Distances enter scaled (metres times pos_scale), so they sit in the range of the other features.
        self.x[:, OFF_OBJ_REL:OFF_OBJ_REL + 3] *= CONFIG["pos_scale"]
        self.rel *= CONFIG["pos_scale"]
        self.src = torch.tensor(src, dtype=torch.long)
        self.dst = torch.tensor(dst, dtype=torch.long)
        n = self.x.shape[0]
        deg = torch.zeros(n).index_add_(0, self.dst, torch.ones(len(dst)))
        self.inv_deg = (1.0 / deg.clamp(min=1)).unsqueeze(1)
        self.pool_node = torch.tensor(pool_node, dtype=torch.long)
        self.pool_seg = torch.tensor(pool_seg, dtype=torch.long)
        self.num_seg = seg
        cnt = torch.zeros(seg).index_add_(0, self.pool_seg, torch.ones(len(pool_seg)))
        self.inv_cnt = (1.0 / cnt.clamp(min=1)).unsqueeze(1)


# ----------------------------------------------------------------------------------------------------------------
# Model
class NeuralTree(torch.nn.Module):
    """GraphSAGE-mean on the H-tree with a relative-position edge term; room = mean of its leaves' embeddings."""

    def __init__(self, input_dim, hidden, layers, classes, dropout):
        super().__init__()
        self.w_self = torch.nn.ModuleList()
        self.w_neigh = torch.nn.ModuleList()
        self.w_edge = torch.nn.ModuleList()
        d = input_dim
        for _ in range(layers):
            self.w_self.append(torch.nn.Linear(d, hidden, bias=True))
            self.w_neigh.append(torch.nn.Linear(d, hidden, bias=False))
            self.w_edge.append(torch.nn.Linear(3, hidden, bias=False))
            d = hidden
        self.head = torch.nn.Linear(hidden, classes)
        self.dropout = dropout

    def forward(self, b):
        h = b.x
        for ws, wn, we in zip(self.w_self, self.w_neigh, self.w_edge):
            agg = torch.zeros_like(h).index_add_(0, b.dst, h[b.src])
            if not CONFIG["agg_sum"]:
                agg = agg * b.inv_deg
            h = torch.relu(ws(h) + wn(agg) + we(b.rel))
            h = torch.nn.functional.dropout(h, self.dropout, self.training)
        pooled = torch.zeros(b.num_seg, h.shape[1]).index_add_(0, b.pool_seg, h[b.pool_node]) * b.inv_cnt
        return self.head(pooled)


def seed_all(seed):
    torch.manual_seed(seed)
    np.random.seed(seed)


def class_weights(labels, num_classes, exponent):
    """Per-class loss weights count^-exponent (0: plain cross-entropy), scaled to mean 1 over the samples."""
    counts = np.bincount(labels, minlength=num_classes).astype(np.float64)
    w = np.where(counts > 0, np.maximum(counts, 1.0) ** -exponent, 0.0)
    w *= len(labels) / float((w[labels]).sum())
    return torch.tensor(w, dtype=torch.float32)


def train_model(train_batch, labels, num_classes, seed, cfg=CONFIG, epochs=None, val_batch=None):
    """Full-batch Adam. With a validation batch, also returns the validation probabilities every 10 epochs."""
    seed_all(seed)
    model = NeuralTree(INPUT_DIM, cfg["hidden"], cfg["layers"], num_classes, cfg["dropout"])
    opt = torch.optim.Adam(model.parameters(), lr=cfg["lr"], weight_decay=cfg["weight_decay"])
    y = torch.tensor(labels, dtype=torch.long)
    weight = class_weights(np.asarray(labels), num_classes, cfg["class_weight"]) if cfg["class_weight"] else None
    curve = []
    total = cfg["epochs"] if epochs is None else epochs
    # swa > 0: the weights returned are the mean of the weights after each of the last swa x total epochs.
    swa_start = int(total * (1.0 - cfg["swa"])) if cfg["swa"] > 0 else total
    swa_sum, swa_n = None, 0
    for epoch in range(total):
        model.train()
        opt.zero_grad()
        loss = torch.nn.functional.cross_entropy(model(train_batch), y, weight=weight,
                                               label_smoothing=float(cfg["label_smoothing"]))
        loss.backward()
        opt.step()
        if epoch >= swa_start:
            with torch.no_grad():
                if swa_sum is None:
                    swa_sum = [p.detach().clone() for p in model.parameters()]
                else:
                    for a, p in zip(swa_sum, model.parameters()):
                        a += p
            swa_n += 1
        if val_batch is not None and epoch % 10 == 9:
            model.eval()
            with torch.no_grad():
                curve.append(torch.softmax(model(val_batch), 1))
    if swa_n > 0:
        with torch.no_grad():
            for a, p in zip(swa_sum, model.parameters()):
                p.copy_(a / swa_n)
    model.eval()
    return (model, curve) if val_batch is not None else model


def choose_epochs(items, labels, num_classes, seed):
    """Training length from an inner stratified split of the training rooms (1 / val_folds held out): the epoch
    count (a multiple of 10) where the ensemble's held-out log-likelihood peaks. Only training rooms are used."""
    labels = np.asarray(labels)
    fold = stratified_folds(labels, int(CONFIG["val_folds"]), np.random.RandomState(50000 + seed))
    tr, va = np.flatnonzero(fold != 0), np.flatnonzero(fold == 0)
    tb, vb = Batch([items[i] for i in tr]), Batch([items[i] for i in va])
    k = int(CONFIG["ensemble"])
    curves = [train_model(tb, labels[tr], num_classes, seed=seed * k + j, epochs=int(CONFIG["max_epochs"]),
                          val_batch=vb)[1] for j in range(k)]
    yv = torch.tensor(labels[va], dtype=torch.long)
    nll = []
    for t in range(len(curves[0])):
        p = torch.stack([c[t] for c in curves]).mean(0)[torch.arange(len(va)), yv]
        nll.append(float(-torch.log(p.clamp(min=1e-12)).mean()))
    return 10 * (int(np.argmin(nll)) + 1)


def train_ensemble(items, labels, num_classes, seed):
    """CONFIG['ensemble'] members from consecutive seeds; the classifier averages their probabilities. With
    val_folds > 1 the training length comes from an inner validation split first (choose_epochs)."""
    k = int(CONFIG["ensemble"])
    epochs = choose_epochs(items, labels, num_classes, seed) if CONFIG["val_folds"] > 1 else int(CONFIG["epochs"])
    batch = Batch(items)
    return [train_model(batch, labels, num_classes, seed=seed * k + j, epochs=epochs) for j in range(k)], epochs


def predict_proba(models, batch):
    with torch.no_grad():
        return torch.stack([torch.softmax(m(batch), 1) for m in models]).mean(0)


# ----------------------------------------------------------------------------------------------------------------
# Logistic-regression head: log object counts + room box geometry, standardised, L2-regularised. On its own the
# baseline the neural tree is measured against; averaged with the neural tree (lr_blend) the shipped classifier.
LR_BOX_FEATURES = ["log_size_x", "log_size_y", "log_size_z", "log_size_max_xy", "log_size_min_xy", "log_area_xy"]
# Then, per name here, log(1 + the footprint of the room's largest object of that name) (0 without one): how big its
# bed, table or sofa is tells a child's room from a bedroom or a dining room from a kitchen, which counts cannot.
# The names are COCO's "furniture" and "appliance" supercategories as the Stanford file spells them; small
# portable things (cups, books, bottles) are left out, their boxes say little. Footprint: max(size_x, MIN_SIZE_M)
# x max(size_y, MIN_SIZE_M), in m^2. The baseline LR the issue compares against has neither (lr_footprints=0).
LR_FOOTPRINT_CLASSES = ["chair", "couch", "plant", "bed", "dining_table", "toilet",
                        "microwave", "oven", "toaster", "sink", "refrigerator"]


def lr_room_features(counts, size, vocab_size, footprints=None, num_footprints=len(LR_FOOTPRINT_CLASSES)):
    """One room's LR features: log(1 + objects per vocabulary name), then the box (LR_BOX_FEATURES, sizes floored at
    MIN_SIZE_M; x and y as stored, not sorted), then (footprints given) log(1 + largest footprint) per
    LR_FOOTPRINT_CLASSES name. counts: {vocabulary index: count}; footprints: {footprint class index: m^2}."""
    nb = vocab_size + len(LR_BOX_FEATURES)
    f = np.zeros(nb + (num_footprints if footprints is not None else 0))
    for i, c in counts.items():
        f[i] = math.log1p(c)
    s = np.log(np.maximum(np.asarray(size, dtype=np.float64)[:3], MIN_SIZE_M))
    f[vocab_size:nb] = [s[0], s[1], s[2], max(s[0], s[1]), min(s[0], s[1]), s[0] + s[1]]
    for i, a in (footprints or {}).items():
        f[nb + i] = math.log1p(a)
    return f


def footprint(size):
    return max(float(size[0]), MIN_SIZE_M) * max(float(size[1]), MIN_SIZE_M)


def add_footprint(footprints, name, size, classes=LR_FOOTPRINT_CLASSES):
    """Keeps the largest footprint per `classes` name."""
    if name in classes:
        i = classes.index(name)
        footprints[i] = max(footprints.get(i, 0.0), footprint(size))


def lr_features(graphs, object_names, footprints=True):
    """LR feature rows of the Stanford rooms: the shipped head's (footprints) or the issue's baseline's (counts and
    box only)."""
    idx = {n: i for i, n in enumerate(object_names)}
    rows = []
    for g in graphs:
        counts, fp = {}, {}
        for n in g["nodes"]:
            if n["type"] != "room":
                counts[idx[n["label"]]] = counts.get(idx[n["label"]], 0) + 1
                add_footprint(fp, n["label"], n["x"][3:6])
        room = next(n for n in g["nodes"] if n["type"] == "room")
        rows.append(lr_room_features(counts, room["x"][3:6], len(object_names), fp if footprints else None))
    return np.array(rows)


def view_footprint_classes(view):
    """A view head's footprint classes: its reads that are LR_FOOTPRINT_CLASSES (none without lr_footprints)."""
    return [c for c in view["reads"] if c in LR_FOOTPRINT_CLASSES] if CONFIG["lr_footprints"] else []


def view_lr_features(graphs, view):
    """LR feature rows of the Stanford rooms as `view` shows them: objects outside its reads are not there (they
    neither count nor give a footprint); the box is the room's."""
    reads, fpc = view["reads"], view_footprint_classes(view)
    idx = {n: i for i, n in enumerate(reads)}
    rows = []
    for g in graphs:
        counts, fp = {}, {}
        for n in g["nodes"]:
            if n["type"] != "room" and n["label"] in idx:
                counts[idx[n["label"]]] = counts.get(idx[n["label"]], 0) + 1
                add_footprint(fp, n["label"], n["x"][3:6], fpc)
        room = next(n for n in g["nodes"] if n["type"] == "room")
        rows.append(lr_room_features(counts, room["x"][3:6], len(reads), fp, len(fpc)))
    return np.array(rows)


def train_view_heads(view_f, y, rooms, num_classes):
    """One LR head per VIEWS entry, trained on `rooms` (indices) of its feature rows view_f[i]."""
    return [train_lr(f[rooms], y[rooms], num_classes, CONFIG["view_lr_l2"]) for f in view_f]


def lr_scene_features(scene, word_names, vocab, footprint_classes=None):
    """LR features of every room of a SceneInput (rows in room node order), objects counted by word name; names
    outside the LR vocabulary (and objects without a word) are not counted. Also each room's coverage: the share of
    its objects that were counted (1 for a room without objects). The C++ RoomClassifier's rule. footprint_classes:
    the head's (default: the main head's, LR_FOOTPRINT_CLASSES when lr_footprints is on)."""
    if footprint_classes is None:
        footprint_classes = LR_FOOTPRINT_CLASSES if CONFIG["lr_footprints"] else []
    vi = {n: i for i, n in enumerate(vocab)}
    rooms = [v for v, l in enumerate(scene.layers) if l == ht.LAYER_ROOM]
    rows, coverage = [], []
    for r in rooms:
        counts, fp, objects, counted = {}, {}, 0, 0
        for v, l in enumerate(scene.layers):
            if l == ht.LAYER_OBJECT and scene.parent_room[v] == r:
                objects += 1
                i = vi.get(word_names[scene.word[v]]) if scene.word[v] >= 0 else None
                if i is not None:
                    counts[i] = counts.get(i, 0) + 1
                    counted += 1
                    add_footprint(fp, word_names[scene.word[v]], scene.size[v], footprint_classes)
        rows.append(lr_room_features(counts, scene.size[r], len(vocab), fp, len(footprint_classes)))
        coverage.append(counted / objects if objects > 0 else 1.0)
    width = len(vocab) + len(LR_BOX_FEATURES) + len(footprint_classes)
    return np.array(rows).reshape(len(rooms), width), np.array(coverage)


def train_lr(f, y, num_classes, l2=1e-2):
    """Multinomial LR by L-BFGS in float64. Returns the head: mean, std (features standardised by them), w
    (features x classes), b."""
    mu, sd = f.mean(0), f.std(0) + 1e-6
    x = torch.tensor((f - mu) / sd, dtype=torch.float64)
    yt = torch.tensor(y, dtype=torch.long)
    w = torch.zeros(f.shape[1], num_classes, dtype=torch.float64, requires_grad=True)
    b = torch.zeros(num_classes, dtype=torch.float64, requires_grad=True)
    opt = torch.optim.LBFGS([w, b], max_iter=500, line_search_fn="strong_wolfe")

    def closure():
        opt.zero_grad()
        loss = torch.nn.functional.cross_entropy(x @ w + b, yt) + l2 * (w * w).sum()
        loss.backward()
        return loss

    opt.step(closure)
    return {"mean": mu, "std": sd, "w": w.detach().numpy().copy(), "b": b.detach().numpy().copy()}


def lr_proba(head, f):
    """Class probabilities of the LR head for feature rows f (float64)."""
    z = ((np.asarray(f, dtype=np.float64) - head["mean"]) / head["std"]) @ head["w"] + head["b"]
    z -= z.max(1, keepdims=True)
    e = np.exp(z)
    return e / e.sum(1, keepdims=True)


def blend_proba(p_nt, p_lr, lr_weight, log_pool, coverage=None):
    """The shipped classifier's output: a convex average of the two models' class probabilities with the LR's weight
    a = lr_weight x coverage (per room: the share of its objects the LR counts; 1 when not given), or (log_pool) the
    normalised weighted geometric mean p_nt^(1-a) p_lr^a."""
    p_nt = np.asarray(p_nt, dtype=np.float64)
    p_lr = np.asarray(p_lr, dtype=np.float64)
    a = lr_weight * (np.ones((p_nt.shape[0], 1)) if coverage is None else np.asarray(coverage, np.float64)[:, None])
    if not log_pool:
        return (1.0 - a) * p_nt + a * p_lr
    z = (1.0 - a) * np.log(np.maximum(p_nt, 1e-30)) + a * np.log(np.maximum(p_lr, 1e-30))
    z -= z.max(1, keepdims=True)
    e = np.exp(z)
    return e / e.sum(1, keepdims=True)


# ----------------------------------------------------------------------------------------------------------------
def stratified_folds(y, k, rng):
    """Per class: shuffle, deal round-robin into k folds (continuing where the previous class stopped)."""
    fold = np.zeros(len(y), dtype=int)
    start = 0
    for c in sorted(set(y)):
        members = np.flatnonzero(np.asarray(y) == c)
        rng.shuffle(members)
        for j, m in enumerate(members):
            fold[m] = (start + j) % k
        start = (start + len(members)) % k
    return fold


def prepare(graphs, object_names, words):
    word_table = word_table_for(words, object_names, object_names)
    set_layout(word_table.shape[1], len(object_names) if CONFIG["room_word_counts"] else 0)
    word_index = {n: i for i, n in enumerate(object_names)}
    scenes = [scene_from_stanford(g, word_index) for g in graphs]
    items = [htree_features(s, word_table) for s in scenes]
    return scenes, items, word_table


_CV = {}  # the data one cv run shares with its fold workers (fork start: copied on write, never pickled)


def cv_fold(task):
    """One (repeat, fold) of the CV: neural tree and LR trained on the other folds. Returns the test rooms' class
    probabilities: each ensemble member's, and the LR's for every l2 in d["lr_l2s"] (the first is CONFIG's)."""
    rep, k = task
    d = _CV
    torch.set_num_threads(1)
    fold = stratified_folds(d["y"], d["folds"], np.random.RandomState(d["seed_base"] + rep))
    tr = np.flatnonzero(fold != k)
    te = np.flatnonzero(fold == k)
    y, items = d["y"], d["items"]
    p_members, ep = None, 0
    if not d["lr_only"]:
        models, ep = train_ensemble([items[i] for i in tr], y[tr], d["classes"], seed=rep * 100 + k)
        test = Batch([items[i] for i in te])
        with torch.no_grad():
            p_members = np.stack([torch.softmax(m(test), 1).double().numpy() for m in models])
    p_lr = [lr_proba(train_lr(d["f"][tr], y[tr], d["classes"], l2), d["f"][te]) for l2 in d["lr_l2s"]]
    # The baseline: LR on log object counts and the room box (no footprints), L2 CONFIG["lr_l2"].
    p_base = lr_proba(train_lr(d["f_base"][tr], y[tr], d["classes"], d["lr_l2s"][0]), d["f_base"][te])
    return rep, k, te, p_members, p_lr, ep, p_base


def write_figures(path, figures, conditions):
    """Figures as JSON, the same form as bench/figures.h: [{name, value, unit, conditions, commit}, ...]."""
    if not path:
        return
    try:
        commit = subprocess.run(["git", "-C", REPO, "describe", "--always", "--dirty=-dirty", "--abbrev=12"],
                                capture_output=True, text=True, check=False).stdout.strip() or "unknown"
    except OSError:
        commit = "unknown"
    with open(path, "w") as f:
        json.dump([{"name": n, "value": float(v), "unit": u, "conditions": conditions, "commit": commit}
                   for n, v, u in figures], f, indent=2)
        f.write("\n")
    print("wrote %s" % path)


def cmd_cv(args):
    graphs, classes, object_names = load_rooms()
    words = load_words()
    y = np.array([classes.index(next(n["label"] for n in g["nodes"] if n["type"] == "room")) for g in graphs])
    _, items, _ = prepare(graphs, object_names, words)
    widths = [it[0].width for it in items]
    print("rooms %d, H-tree nodes %d, width max %d mean %.2f" %
          (len(items), sum(len(it[0].members) for it in items), max(widths), np.mean(widths)))
    l2s = [CONFIG["lr_l2"]] + ([v for v in SWEEP_LR_L2 if v != CONFIG["lr_l2"]] if args.sweep else [])
    _CV.update(y=y, items=items, f=lr_features(graphs, object_names, bool(CONFIG["lr_footprints"])),
               f_base=lr_features(graphs, object_names, False), classes=len(classes), folds=args.folds,
               seed_base=args.seed_base, lr_only=args.lr_only, lr_l2s=l2s)
    tasks = [(rep, k) for rep in range(args.repeats) for k in range(args.folds)]
    t0 = time.time()
    # Every fold seeds its own training, so the figures do not depend on --jobs.
    if args.jobs > 1:
        import multiprocessing
        with multiprocessing.get_context("fork").Pool(args.jobs) as pool:
            results = pool.map(cv_fold, tasks, chunksize=1)
    else:
        results = [cv_fold(t) for t in tasks]
    wall_s = time.time() - t0
    results.sort(key=lambda r: (r[0], r[1]))
    # Out-of-fold probabilities per repeat: every room is a test room exactly once per repeat.
    n, c = len(y), len(classes)
    members = 0 if args.lr_only else results[0][3].shape[0]
    oof_members = np.zeros((args.repeats, members, n, c))
    oof_lr = np.zeros((args.repeats, len(l2s), n, c))
    oof_base = np.zeros((args.repeats, n, c))
    for rep, k, te, p_members, p_lr, _, p_base in results:
        if members:
            oof_members[rep][:, te] = p_members
        for j in range(len(l2s)):
            oof_lr[rep, j, te] = p_lr[j]
        oof_base[rep, te] = p_base
    epochs_used = [r[5] for r in results if r[5]]
    if args.oof:  # out-of-fold probabilities, for trying other blends offline (tuning splits only)
        np.savez_compressed(args.oof, y=y, members=oof_members, lr=oof_lr, lr_l2=np.array(l2s), lr_base=oof_base)
        print("wrote %s" % args.oof)

    def accuracy(p):  # per repeat
        return np.array([float((p[rep].argmax(1) == y).mean()) for rep in range(args.repeats)])

    def fold_accuracy(p):
        return np.array([float((p[r[0]][r[2]].argmax(1) == y[r[2]]).mean()) for r in results])

    p_lr = oof_lr[:, 0]
    p_nt = oof_members.mean(1) if members else np.zeros_like(p_lr)
    a_blend, log_pool = float(CONFIG["lr_blend"]), bool(CONFIG["blend_log"])
    p_blend = np.stack([blend_proba(p_nt[rep], p_lr[rep], a_blend, log_pool) for rep in range(args.repeats)])
    acc_lr = accuracy(p_lr)
    acc_base = accuracy(oof_base)
    acc_nt = accuracy(p_nt) if members else np.zeros(args.repeats)
    acc_blend = accuracy(p_blend) if members else np.zeros(args.repeats)
    for rep in range(args.repeats):
        if members:
            print("repeat %d: neural tree %.2f %%, LR baseline %.2f %%, LR head %.2f %%, blend %.2f %%" %
                  (rep, 100 * acc_nt[rep], 100 * acc_base[rep], 100 * acc_lr[rep], 100 * acc_blend[rep]))
        else:
            print("repeat %d: LR baseline %.2f %%, LR head %.2f %%" % (rep, 100 * acc_base[rep], 100 * acc_lr[rep]))
    print("cv time %.0f s (%d jobs)" % (wall_s, args.jobs))
    blend_name = "blend (LR weight %.2f, %s)" % (a_blend, "log-linear pool" if log_pool else "linear average")
    lr_name = "LR head (counts, box%s)" % (", footprints" if CONFIG["lr_footprints"] else "")
    for name, acc, p in (("neural tree", acc_nt, p_nt), ("LR baseline (counts, box)", acc_base, oof_base),
                         (lr_name, acc_lr, p_lr), (blend_name, acc_blend, p_blend)):
        if members or name.startswith("LR"):
            print("%-40s %.2f +- %.2f %% (std over repeats; over the %d folds +- %.2f)" %
                  (name + ":", 100 * np.mean(acc), 100 * np.std(acc), len(results), 100 * np.std(fold_accuracy(p))))
    if epochs_used:
        print("training epochs per fold: mean %.0f, min %d, max %d" %
              (np.mean(epochs_used), min(epochs_used), max(epochs_used)))
    if args.sweep:
        # Tuning aid (use a tuning --seed-base, never the reported split): accuracy (mean over repeats) per LR l2,
        # blend mode and LR weight, and of the first j ensemble members alone.
        weights = [i / 10 for i in range(11)] if members else [1.0]
        print("sweep, accuracy %% over LR weight %s" % " ".join("%5.1f" % a for a in weights))
        for j, l2 in enumerate(l2s):
            for lp in ((0, 1) if members else (0,)):
                accs = [np.mean(accuracy(np.stack([blend_proba(p_nt[r], oof_lr[r, j], a, lp)
                                                   for r in range(args.repeats)]) if members else oof_lr[:, j]))
                        for a in weights]
                print("  lr_l2 %-7g %-6s %s" %
                      (l2, "log" if lp else "linear", " ".join("%5.2f" % (100 * v) for v in accs)))
        for j in range(1, members + 1):
            print("  neural tree, first %d member(s): %.2f %%; linear blend with LR weight %.2f: %.2f %%" %
                  (j, 100 * np.mean(accuracy(oof_members[:, :j].mean(1))), a_blend,
                   100 * np.mean(accuracy(np.stack([blend_proba(oof_members[r, :j].mean(0), p_lr[r], a_blend, 0)
                                                      for r in range(args.repeats)])))))
    print("config", json.dumps(CONFIG))
    # logistic_regression_*: the baseline (counts and box); lr_head_*: the LR the blend uses.
    figures = [("logistic_regression_cv_accuracy", 100 * np.mean(acc_base), "%"),
               ("logistic_regression_cv_accuracy_std_repeats", 100 * np.std(acc_base), "%"),
               ("lr_head_cv_accuracy", 100 * np.mean(acc_lr), "%"),
               ("lr_head_cv_accuracy_std_repeats", 100 * np.std(acc_lr), "%")]
    if members:
        figures = [("neural_tree_cv_accuracy", 100 * np.mean(acc_nt), "%"),
                   ("neural_tree_cv_accuracy_std_repeats", 100 * np.std(acc_nt), "%")] + figures + [
                   ("blend_cv_accuracy", 100 * np.mean(acc_blend), "%"),
                   ("blend_cv_accuracy_std_repeats", 100 * np.std(acc_blend), "%")]
    figures.append(("cv_wall_time", wall_s, "s"))
    write_figures(args.json, figures,
                  "Stanford3DSG_rooms 482 rooms, %dx%d stratified CV, seed base %d, %d jobs, config %s" %
                  (args.repeats, args.folds, args.seed_base, args.jobs, json.dumps(CONFIG, sort_keys=True)))


# ----------------------------------------------------------------------------------------------------------------
# Semi-supervised node classification (the paper's protocol): every room and object node gets a label, 70/10/20
# split over all nodes, 100 runs; node labels pooled from all leaves of that node.
def cmd_ssl(args):
    graphs, classes, object_names = load_rooms()
    words = load_words()
    word_index = {n: i for i, n in enumerate(object_names)}
    # The paper's features here: centroid-free geometry, relative positions; no word vectors (labels are targets).
    xs, rels, src, dst, lab, leaf_node, leaf_seg = [], [], [], [], [], [], []
    offset = 0
    seg = 0
    for g in graphs:
        s = scene_from_stanford(g, word_index)
        s.word = [-1] * len(s.word)
        h, x, rel, _, _ = htree_features(s, np.zeros((len(object_names), WORD_DIM), dtype=np.float32))
        # Rooms and objects alike carry their log box size; offsets to the room stay on objects.
        for i, members in enumerate(h.members):
            if len(members) == 1 and s.layers[members[0]] == ht.LAYER_ROOM:
                x[i, OFF_OBJ_SIZE:OFF_OBJ_SIZE + 3] = x[i, OFF_ROOM_SIZE:OFF_ROOM_SIZE + 3]
        xs.append(x)
        rels.append(rel)
        for a, b in h.edges:
            src += [offset + a, offset + b]
            dst += [offset + b, offset + a]
        for v, n in enumerate(g["nodes"]):
            lab.append(classes.index(n["label"]) if n["type"] == "room" else len(classes) + word_index[n["label"]])
            for i, members in enumerate(h.members):
                if members == [v]:
                    leaf_node.append(offset + i)
                    leaf_seg.append(seg + v)
        seg += len(g["nodes"])
        offset += x.shape[0]

    class B:
        pass

    b = B()
    b.x = torch.from_numpy(np.concatenate(xs))
    b.rel = torch.from_numpy(np.concatenate(rels))
    b.src = torch.tensor(src)
    b.dst = torch.tensor(dst)
    deg = torch.zeros(offset).index_add_(0, b.dst, torch.ones(len(dst)))
    b.inv_deg = (1.0 / deg.clamp(min=1)).unsqueeze(1)
    b.pool_node = torch.tensor(leaf_node)
    b.pool_seg = torch.tensor(leaf_seg)
    b.num_seg = seg
    cnt = torch.zeros(seg).index_add_(0, b.pool_seg, torch.ones(len(leaf_seg)))
    b.inv_cnt = (1.0 / cnt.clamp(min=1)).unsqueeze(1)
    y = torch.tensor(lab)
    is_room = y < len(classes)
    nclass = len(classes) + len(object_names)
    accs = []
    t0 = time.time()
    for run in range(args.runs):
        rng = np.random.RandomState(run)
        perm = rng.permutation(seg)
        ntr, nva = int(0.7 * seg), int(0.1 * seg)
        tr, va, te = perm[:ntr], perm[ntr:ntr + nva], perm[ntr + nva:]
        seed_all(run)
        model = NeuralTree(INPUT_DIM, 64, 3, nclass, 0.25)
        opt = torch.optim.Adam(model.parameters(), lr=0.005, weight_decay=1e-4)
        best_va, best_te = -1.0, 0.0
        room_only = is_room[:, None] & (torch.arange(nclass) >= len(classes))[None, :]
        object_only = ~is_room[:, None] & (torch.arange(nclass) < len(classes))[None, :]

        def masked(logits):
            # A room node may only take a room label and an object an object label.
            return logits.masked_fill(room_only, -1e9).masked_fill(object_only, -1e9)

        for epoch in range(args.epochs):
            model.train()
            opt.zero_grad()
            torch.nn.functional.cross_entropy(masked(model(b))[tr], y[tr]).backward()
            opt.step()
            if epoch % 20 == 19:  # model selection on the validation nodes, in eval mode
                model.eval()
                with torch.no_grad():
                    pred = masked(model(b)).argmax(1)
                a_va = float((pred[va] == y[va]).float().mean())
                if a_va > best_va:
                    best_va, best_te = a_va, float((pred[te] == y[te]).float().mean())
        accs.append(best_te)
        if run % 10 == 9:
            print("run %d: mean test %.2f %% (%.0f s)" % (run, 100 * np.mean(accs), time.time() - t0), flush=True)
    print("semi-supervised node classification (70/10/20, %d runs): %.2f +- %.2f %%" %
          (args.runs, 100 * np.mean(accs), 100 * np.std(accs)))
    write_figures(args.json, [("semi_supervised_node_accuracy", 100 * np.mean(accs), "%"),
                              ("semi_supervised_node_accuracy_std", 100 * np.std(accs), "%"),
                              ("semi_supervised_wall_time", time.time() - t0, "s")],
                  "Stanford3DSG_rooms, all room and object nodes, 70/10/20 split, %d runs, %d epochs" %
                  (args.runs, args.epochs))


# ----------------------------------------------------------------------------------------------------------------
def f32list(t):
    """Exact float32 values as JSON numbers (9 significant digits round-trip a float32)."""
    return [float("%.9g" % v) for v in np.asarray(t, dtype=np.float32).ravel()]


def f32b64(t):
    """A weight array as base64 of little-endian float32 (exact, about a third of the text form's size)."""
    return base64.b64encode(np.asarray(t, dtype="<f4").ravel().tobytes()).decode("ascii")


def from_b64(text):
    return np.frombuffer(base64.b64decode(text), dtype="<f4").copy()


def member_json(model):
    layers = []
    for ws, wn, we in zip(model.w_self, model.w_neigh, model.w_edge):
        layers.append({
            "in": ws.in_features, "out": ws.out_features,
            "w_self": f32b64(ws.weight.detach()), "b_self": f32b64(ws.bias.detach()),
            "w_neigh": f32b64(wn.weight.detach()), "w_edge": f32b64(we.weight.detach()),
        })
    return {"layers": layers,
            "head": {"in": model.head.in_features, "out": model.head.out_features,
                     "w": f32b64(model.head.weight.detach()), "b": f32b64(model.head.bias.detach())}}


def lr_head_json(head, vocab, footprints=None, lr_weight=None):
    if footprints is None:
        footprints = LR_FOOTPRINT_CLASSES if CONFIG["lr_footprints"] else []
    if lr_weight is None:
        lr_weight = CONFIG["lr_blend"]
    return {
        "features": {"object_counts": {"transform": "log1p", "vocabulary": list(vocab)},
                     "room_box": LR_BOX_FEATURES, "min_size_m": MIN_SIZE_M,
                     "largest_footprint": {"transform": "log1p", "classes": list(footprints)},
                     "definition": "x = [log(1 + objects per vocabulary name in the room, by the object's word-table "
                                   "row name), log(max(size_x, min_size_m)), log(max(size_y, ..)), log(max(size_z, "
                                   "..)), max and min of the two horizontal logs, their sum, then per "
                                   "largest_footprint class log(1 + max over the room's objects of that name of "
                                   "max(size_x, min_size_m) max(size_y, min_size_m)), 0 without one]; p = "
                                   "softmax(((x - mean) / std) w^T + b)"},
        "num_features": len(vocab) + len(LR_BOX_FEATURES) + len(footprints), "num_classes": head["w"].shape[1],
        "mean": f32b64(head["mean"]), "std": f32b64(head["std"]),
        "w": f32b64(head["w"].T), "b": f32b64(head["b"]),  # w stored classes x features (out x in, as the layers)
        "blend": {"lr_weight": float(lr_weight), "pool": "log" if CONFIG["blend_log"] else "linear",
                  "weight_by_coverage": True},
    }


def view_heads_json(view_heads):
    """The weights file's view_heads (version 4): per VIEWS entry its name, label map and LR head."""
    return [{"name": v["name"], "label_map": v["label_map"],
             "lr_head": lr_head_json(h, v["reads"], view_footprint_classes(v), CONFIG["view_lr_blend"])}
            for v, h in zip(VIEWS, view_heads)]


def write_weights(models, classes, word_names, word_table, path, lr_head, lr_vocab, view_heads):
    doc = {
        "header": {"format": "qsg_neural_tree_weights", "version": WEIGHTS_VERSION,
                   "trained_on": "Stanford3DSG_rooms.json (482 rooms), bench/neural_tree/train_neural_tree.py train",
                   "config": CONFIG},
        "input_dim": INPUT_DIM, "hidden": CONFIG["hidden"], "num_layers": CONFIG["layers"],
        "num_classes": len(classes), "num_types": ht.NUM_TYPES, "word_dim": WORD_DIM, "min_size_m": MIN_SIZE_M,
        "position_scale": CONFIG["pos_scale"], "aggregation": "sum" if CONFIG["agg_sum"] else "mean",
        "offsets": {"type": OFF_TYPE, "word": OFF_WORD, "object_size": OFF_OBJ_SIZE,
                    "object_relative_position": OFF_OBJ_REL, "room_size": OFF_ROOM_SIZE,
                    "room_object_count": OFF_ROOM_COUNT, "object_label_count": OFF_OBJ_LABEL_COUNT if CONFIG["label_count"] else -1},
        "classes": classes,
        "class_room_labels": [ROOM_LABEL_MAP[c] for c in classes],
        "words": {n: f32b64(v) for n, v in zip(word_names, word_table)},
        "members": [member_json(m) for m in models],
        "lr_head": lr_head_json(lr_head, lr_vocab),
        "view_heads": view_heads_json(view_heads),
    }
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        json.dump(doc, f, separators=(",", ":"))
    print("wrote %s (%d bytes, %d members)" % (path, os.path.getsize(path), len(models)))


def round_trip_models(models, path):
    """Reload the weights as written (float32 text) so the fixture's expectations use exactly what C++ reads."""
    with open(path) as f:
        doc = json.load(f)
    with torch.no_grad():
        for model, member in zip(models, doc["members"]):
            for l, (ws, wn, we) in zip(member["layers"], zip(model.w_self, model.w_neigh, model.w_edge)):
                ws.weight.copy_(torch.tensor(from_b64(l["w_self"])).view_as(ws.weight))
                ws.bias.copy_(torch.tensor(from_b64(l["b_self"])))
                wn.weight.copy_(torch.tensor(from_b64(l["w_neigh"])).view_as(wn.weight))
                we.weight.copy_(torch.tensor(from_b64(l["w_edge"])).view_as(we.weight))
            model.head.weight.copy_(torch.tensor(from_b64(member["head"]["w"])).view_as(model.head.weight))
            model.head.bias.copy_(torch.tensor(from_b64(member["head"]["b"])))
    views = [head_from_json(v["lr_head"]) for v in doc["view_heads"]]
    return {n: from_b64(v) for n, v in doc["words"].items()}, head_from_json(doc["lr_head"]), views


def head_from_json(lr):
    """An LR head as stored (float32), in float64."""
    c, f = lr["num_classes"], lr["num_features"]
    return {"mean": from_b64(lr["mean"]).astype(np.float64), "std": from_b64(lr["std"]).astype(np.float64),
            "w": from_b64(lr["w"]).astype(np.float64).reshape(c, f).T.copy(), "b": from_b64(lr["b"]).astype(np.float64)}


def fixture_scenes(graphs, object_names):
    """A few Stanford rooms plus one synthetic two-room building with mpcat40 labels and room-room edges."""
    word_index = {n: i for i, n in enumerate(object_names)}
    picked = []
    for g in graphs:
        n = len(g["nodes"]) - 1
        if n in (1, 3, 6, 12) and all(len(p["nodes"]) - 1 != n for p in picked):
            picked.append(g)
    scenes = []
    for g in picked:
        s = scene_from_stanford(g, word_index)
        s.word_names = [object_names[w] if w >= 0 else "" for w in s.word]
        scenes.append(s)
    # Building 0, rooms 1-2, objects 3-8: labels by mpcat40 name (the shipped pipeline's vocabulary).
    layers = [ht.LAYER_BUILDING, ht.LAYER_ROOM, ht.LAYER_ROOM] + [ht.LAYER_OBJECT] * 6
    names = ["", "", "", "bed", "chest_of_drawers", "lighting", "toilet", "sink", "towel"]
    cen = [[2, 1, 1.2], [0, 0, 1.2], [4, 2, 1.2], [-0.5, 0.3, 0.4], [1, -1, 0.5], [0.2, 0.2, 2.2],
           [4.5, 2.5, 0.4], [3.6, 2.2, 0.8], [4.2, 1.4, 1.0]]
    size = [[8, 5, 2.6], [4, 3.5, 2.5], [2.5, 2, 2.5], [2, 1.6, 0.6], [0.9, 0.5, 1.0], [0.4, 0.4, 0.2],
            [0.5, 0.7, 0.8], [0.6, 0.5, 0.3], [0.1, 0.6, 0.8]]
    edges = [(0, 1), (0, 2), (1, 2), (1, 3), (1, 4), (1, 5), (2, 6), (2, 7), (2, 8), (3, 4), (3, 5), (6, 7), (7, 8)]
    s = SceneInput(layers, [-1] * 9, cen, size, edges, [-1, -1, -1, 1, 1, 1, 2, 2, 2])
    s.word_names = names
    scenes.append(s)
    return scenes


def cmd_train(args):
    # core/neural_tree implements the shipped feature set only; the ablation switches stay in cv.
    if CONFIG["box_relative"] or CONFIG["plain_graph"] or CONFIG["room_word_counts"]:
        sys.exit("train: box_relative, plain_graph and room_word_counts are cv-only ablations; core/neural_tree does "
                 "not read them")
    graphs, classes, object_names = load_rooms()
    words = load_words()
    y = np.array([classes.index(next(n["label"] for n in g["nodes"] if n["type"] == "room")) for g in graphs])
    _, items, word_table = prepare(graphs, object_names, words)
    models, epochs = train_ensemble(items, y, len(classes), seed=7)
    print("epochs %d" % epochs)
    f_lr = lr_features(graphs, object_names, bool(CONFIG["lr_footprints"]))
    lr_head = train_lr(f_lr, y, len(classes), CONFIG["lr_l2"])
    view_f = [view_lr_features(graphs, v) for v in VIEWS]
    view_heads = train_view_heads(view_f, y, np.arange(len(graphs)), len(classes))
    word_names = list(object_names) + [m for m in MPCAT40 if m not in object_names]
    table = word_table_for(words, word_names, object_names)
    write_weights(models, classes, word_names, table, args.weights, lr_head, object_names, view_heads)
    stored, stored_lr, stored_views = round_trip_models(models, args.weights)
    a_blend, log_pool = float(CONFIG["lr_blend"]), bool(CONFIG["blend_log"])
    p_nt = predict_proba(models, Batch(items)).double().numpy()
    p_lr = lr_proba(stored_lr, f_lr)
    for name, p in (("neural tree", p_nt), ("LR head", p_lr), ("blend", blend_proba(p_nt, p_lr, a_blend, log_pool))):
        print("training accuracy, %s: %.2f %%" % (name, 100 * float((p.argmax(1) == y).mean())))
    for v, h, f in zip(VIEWS, stored_views, view_f):
        print("training accuracy, view head %s on its view: %.2f %%" %
              (v["name"], 100 * float((lr_proba(h, f).argmax(1) == y).mean())))
    # Parity fixture: inputs exactly as the C++ API takes them, and the PyTorch room probabilities.
    cases = []
    for s in fixture_scenes(graphs, object_names):
        wt = np.stack([stored[n] if n in stored else np.zeros(WORD_DIM, np.float32) for n in word_names])
        s.word = [word_names.index(n) if n else -1 for n in s.word_names]
        item = htree_features(s, wt)
        b = Batch([item])
        nt = predict_proba(models, b).double().numpy()
        f, coverage = lr_scene_features(s, word_names, object_names)  # rooms in node order, as the Batch's segments
        lr = lr_proba(stored_lr, f)
        probs = blend_proba(nt, lr, a_blend, log_pool, coverage)
        # The same input classified with each view head (RoomClassifier::Config::perceived_labels): the neural tree
        # unchanged, the view head in place of the LR head, the view's blend weight; a room without a read object
        # takes the LR head alone (empty_rooms_from_box, on in the C++ default), as here.
        views = []
        for v, h in zip(VIEWS, stored_views):
            vf, vcov = lr_scene_features(s, word_names, v["reads"], view_footprint_classes(v))
            vlr = lr_proba(h, vf)
            vp = blend_proba(nt, vlr, float(CONFIG["view_lr_blend"]), log_pool, vcov)
            views.append({"name": v["name"], "reads": v["reads"], "lr_features": vf.tolist(),
                          "lr_probabilities": [f32list(r) for r in vlr], "lr_coverage": vcov.tolist(),
                          "probabilities": [f32list(r) for r in vp]})
        cases.append({
            "layers": s.layers, "labels": s.word_names, "centroids": s.centroid.ravel().tolist(),
            "sizes": s.size.ravel().tolist(), "edges": [list(e) for e in s.edges],
            "htree_nodes": len(item[0].members), "htree_width": item[0].width,
            "htree_types": item[0].types,
            "rooms": [r for _, r in b.room_of_seg],
            "nt_probabilities": [f32list(r) for r in nt], "lr_features": f.tolist(),
            "lr_probabilities": [f32list(r) for r in lr], "lr_coverage": coverage.tolist(),
            # The classifier's output (the blend) and its log, as C++ reports them.
            "log_probabilities": [f32list(np.log(np.maximum(r, 1e-30))) for r in probs],
            "probabilities": [f32list(r) for r in probs],
            "views": views,
        })
    with open(args.fixture, "w") as f:
        json.dump({"header": {"format": "qsg_neural_tree_parity", "version": WEIGHTS_VERSION,
                              "weights": os.path.relpath(args.weights, REPO),
                              "blend": {"lr_weight": a_blend, "pool": "log" if log_pool else "linear",
                                        "weight_by_coverage": True}},
                   "cases": cases}, f, indent=1)
    print("wrote %s (%d cases)" % (args.fixture, len(cases)))


def folds_task(task):
    """One (repeat, fold) for cmd_folds: the neural tree and the LR head trained on the other folds (the same
    split and seeds as cv_fold), written as a weights file. Returns (name, test room indices)."""
    rep, k = task
    d = _CV
    torch.set_num_threads(1)
    fold = stratified_folds(d["y"], d["folds"], np.random.RandomState(d["seed_base"] + rep))
    tr, te = np.flatnonzero(fold != k), np.flatnonzero(fold == k)
    models, _ = train_ensemble([d["items"][i] for i in tr], d["y"][tr], len(d["classes"]), seed=rep * 100 + k)
    lr_head = train_lr(d["f"][tr], d["y"][tr], len(d["classes"]), CONFIG["lr_l2"])
    view_heads = train_view_heads(d["view_f"], d["y"], tr, len(d["classes"]))
    name = "r%d_f%d" % (rep, k)
    write_weights(models, d["classes"], d["word_names"], d["table"], os.path.join(d["out"], name + ".json"), lr_head,
                  d["object_names"], view_heads)
    return name, te.tolist()


def cmd_folds(args):
    """The cv's (repeat, fold) models as weights files in --out, with folds.json naming each file's held-out rooms
    (indices into the Stanford file's graphs): bench/neural_tree/labels_eval --cv-weights DIR scores the C++
    classifier on them under label shift."""
    graphs, classes, object_names = load_rooms()
    words = load_words()
    y = np.array([classes.index(next(n["label"] for n in g["nodes"] if n["type"] == "room")) for g in graphs])
    _, items, _ = prepare(graphs, object_names, words)
    word_names = list(object_names) + [m for m in MPCAT40 if m not in object_names]
    os.makedirs(args.out, exist_ok=True)
    _CV.update(y=y, items=items, f=lr_features(graphs, object_names, bool(CONFIG["lr_footprints"])),
               classes=classes, folds=args.folds, seed_base=args.seed_base, out=args.out, word_names=word_names,
               table=word_table_for(words, word_names, object_names), object_names=object_names,
               view_f=[view_lr_features(graphs, v) for v in VIEWS])
    tasks = [(rep, k) for rep in range(args.repeats) for k in range(args.folds)]
    t0 = time.time()
    if args.jobs > 1:
        import multiprocessing
        with multiprocessing.get_context("fork").Pool(args.jobs) as pool:
            results = pool.map(folds_task, tasks, chunksize=1)
    else:
        results = [folds_task(t) for t in tasks]
    index = {"seed_base": args.seed_base, "repeats": args.repeats, "folds": args.folds, "config": CONFIG,
             "test": {name: te for name, te in sorted(results)}}
    with open(os.path.join(args.out, "folds.json"), "w") as f:
        json.dump(index, f)
    print("wrote %d fold models and folds.json to %s in %.0f s" % (len(results), args.out, time.time() - t0))


def cmd_add_views(args):
    """Rewrites weights files as version 4 with VIEWS' heads trained on the rooms each file's neural tree and LR head
    were trained on, the rest of the file as it is (the training is deterministic: the same as train or folds at
    version 4, without retraining the neural tree). --weights FILE: all rooms; --folds DIR: every fold file of
    folds.json (each on the rooms it does not hold out), written with folds.json to --out."""
    graphs, classes, _ = load_rooms()
    y = np.array([classes.index(next(n["label"] for n in g["nodes"] if n["type"] == "room")) for g in graphs])
    view_f = [view_lr_features(graphs, v) for v in VIEWS]
    jobs = []
    if args.weights:
        jobs.append((args.weights, args.out or args.weights, np.arange(len(graphs))))
    if args.folds:
        with open(os.path.join(args.folds, "folds.json")) as f:
            index = json.load(f)
        os.makedirs(args.out, exist_ok=True)
        for name, te in sorted(index["test"].items()):
            held = set(te)
            jobs.append((os.path.join(args.folds, name + ".json"), os.path.join(args.out, name + ".json"),
                         np.array([i for i in range(len(graphs)) if i not in held])))
        index["config"] = dict(index["config"], view_lr_l2=CONFIG["view_lr_l2"], view_lr_blend=CONFIG["view_lr_blend"])
        with open(os.path.join(args.out, "folds.json"), "w") as f:
            json.dump(index, f)
    for src, dst, rooms in jobs:
        with open(src) as f:
            doc = json.load(f)
        if doc["classes"] != classes:
            sys.exit("add-views: %s: classes differ from the Stanford file's" % src)
        doc["header"]["version"] = WEIGHTS_VERSION
        doc["header"]["config"] = dict(doc["header"]["config"], view_lr_l2=CONFIG["view_lr_l2"],
                                       view_lr_blend=CONFIG["view_lr_blend"])
        doc["view_heads"] = view_heads_json(train_view_heads(view_f, y, rooms, len(classes)))
        with open(dst, "w") as f:
            json.dump(doc, f, separators=(",", ":"))
    print("add-views: wrote %d weights files" % len(jobs))


def cmd_view_ceiling(args):
    """How well several model families do on the Stanford rooms as a view (VIEWS entry) shows them: the view head's
    LR, an MLP and k-nearest neighbours, each fit on the view's training folds, in the cv's 5x5 stratified CV (room-
    label accuracy; also on the rooms in which the view shows nothing). When they agree, the ceiling is the view's
    missing evidence, not the model (bench/results/room_labels.md, target (d))."""
    graphs, classes, _ = load_rooms()
    y = np.array([classes.index(next(n["label"] for n in g["nodes"] if n["type"] == "room")) for g in graphs])
    label = np.array([ROOM_LABEL_MAP[c] for c in classes])
    view = next(v for v in VIEWS if v["name"] == args.view)
    f = view_lr_features(graphs, view)
    empty = f[:, :len(view["reads"])].sum(1) == 0
    k_classes = len(classes)

    def standardise(tr, te):
        mu, sd = f[tr].mean(0), f[tr].std(0) + 1e-6
        return (f[tr] - mu) / sd, (f[te] - mu) / sd

    def lr(tr, te):
        return lr_proba(train_lr(f[tr], y[tr], k_classes, CONFIG["view_lr_l2"]), f[te]).argmax(1)

    def mlp(tr, te):
        torch.manual_seed(0)
        a, b = standardise(tr, te)
        m = torch.nn.Sequential(torch.nn.Linear(f.shape[1], 64), torch.nn.ReLU(), torch.nn.Dropout(0.2),
                                torch.nn.Linear(64, 64), torch.nn.ReLU(), torch.nn.Linear(64, k_classes))
        opt = torch.optim.Adam(m.parameters(), lr=3e-3, weight_decay=1e-3)
        x, t = torch.tensor(a, dtype=torch.float32), torch.tensor(y[tr])
        for _ in range(400):
            opt.zero_grad()
            torch.nn.functional.cross_entropy(m(x), t).backward()
            opt.step()
        m.eval()
        with torch.no_grad():
            return m(torch.tensor(b, dtype=torch.float32)).argmax(1).numpy()

    def knn(k):
        def run(tr, te):
            a, b = standardise(tr, te)
            d = ((b[:, None, :] - a[None, :, :]) ** 2).sum(2)
            return np.array([np.bincount(y[tr][np.argsort(row)[:k]], minlength=k_classes).argmax() for row in d])
        return run

    figures = []
    for name, fit in (("lr", lr), ("mlp", mlp), ("knn7", knn(7)), ("knn15", knn(15))):
        right, right_empty = [], []
        for rep in range(args.repeats):
            fold = stratified_folds(y, 5, np.random.RandomState(args.seed_base + rep))
            for k in range(5):
                tr, te = np.flatnonzero(fold != k), np.flatnonzero(fold == k)
                ok = label[fit(tr, te)] == label[y[te]]
                right += list(ok)
                right_empty += list(ok[empty[te]])
        print("%-6s %s view, %dx5 CV room-label accuracy %.1f %% (rooms with nothing visible: %.1f %%)" %
              (name, view["name"], args.repeats, 100 * np.mean(right), 100 * np.mean(right_empty)))
        figures += [("view_ceiling.%s.%s.accuracy" % (view["name"], name), np.mean(right), "fraction"),
                    ("view_ceiling.%s.%s.accuracy_nothing_visible" % (view["name"], name), np.mean(right_empty),
                     "fraction")]
    print("rooms with nothing the view shows: %d of %d" % (empty.sum(), len(y)))
    figures.append(("view_ceiling.%s.rooms_nothing_visible" % view["name"], float(empty.sum()), "rooms"))
    write_figures(args.json, figures, "Stanford3DSG rooms as view %s shows them, %dx5 stratified CV, seed base %d" %
                  (view["name"], args.repeats, args.seed_base))


def main():
    torch.set_num_threads(1)
    torch.use_deterministic_algorithms(True)
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("cv")
    c.add_argument("--repeats", type=int, default=5)
    c.add_argument("--folds", type=int, default=5)
    c.add_argument("--lr-only", action="store_true", help="only the logistic-regression baseline")
    c.add_argument("--jobs", type=int, default=1, help="folds trained in parallel processes (one torch thread each)")
    c.add_argument("--seed-base", type=int, default=1000, help="fold split seeds seed_base .. seed_base + repeats - 1")
    c.add_argument("--sweep", action="store_true",
                   help="also print accuracy over LR l2, blend weight and mode, and ensemble size (for tuning splits)")
    c.add_argument("--oof", default="", help="also save the out-of-fold class probabilities to this .npz file")
    fo = sub.add_parser("folds")
    fo.add_argument("--out", required=True, help="folder for the fold weights files and folds.json")
    fo.add_argument("--repeats", type=int, default=5)
    fo.add_argument("--folds", type=int, default=5)
    fo.add_argument("--jobs", type=int, default=1)
    fo.add_argument("--seed-base", type=int, default=1000)
    s = sub.add_parser("ssl")
    s.add_argument("--runs", type=int, default=100)
    s.add_argument("--epochs", type=int, default=300)
    t = sub.add_parser("train")
    t.add_argument("--weights", default=WEIGHTS_OUT)
    t.add_argument("--fixture", default=FIXTURE_OUT)
    av = sub.add_parser("add-views")
    av.add_argument("--weights", default="", help="a weights file trained on all rooms")
    av.add_argument("--folds", default="", help="a folds --out folder")
    av.add_argument("--out", default="", help="output file (--weights; default: in place) or folder (--folds)")
    for sp in (c, s):
        sp.add_argument("--json", default="", help="also write the figures to this JSON file")
    vc = sub.add_parser("view-ceiling")
    vc.add_argument("--view", default="segmentation_pascal_voc")
    vc.add_argument("--repeats", type=int, default=5)
    vc.add_argument("--seed-base", type=int, default=1000)
    vc.add_argument("--json", default="", help="also write the figures to this JSON file")
    for sp in (c, s, t, fo, av, vc):
        sp.add_argument("--set", action="append", default=[], help="override a CONFIG entry, key=value")
    args = p.parse_args()
    for kv in getattr(args, "set", []):
        k, v = kv.split("=")
        CONFIG[k] = type(CONFIG[k])(float(v)) if CONFIG[k] is not None else float(v)
    {"cv": cmd_cv, "ssl": cmd_ssl, "train": cmd_train, "folds": cmd_folds, "add-views": cmd_add_views,
     "view-ceiling": cmd_view_ceiling}[args.cmd](args)


if __name__ == "__main__":
    main()
