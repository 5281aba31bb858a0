#!/usr/bin/env python3
"""Writes a world (drivers/world/WORLD_FORMAT.md) of N identical bedrooms along a hallway: same size, same door
position, same furniture at the same place, same materials. Perceptual aliasing for loop closure: every room looks
like every other, so a closure between two different rooms is false and must not survive the optimization.

    bench/loop_closure/worlds/make_identical_rooms.py --rooms 4 > bench/loop_closure/worlds/identical_rooms_4.json
"""
import argparse
import json


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rooms", type=int, default=4, help="identical rooms (2..16)")
    ap.add_argument("--room-size", type=float, default=4.0, help="room edge length in metres")
    args = ap.parse_args()
    n, s = args.rooms, args.room_size
    if not 2 <= n <= 16 or not 3.0 <= s <= 8.0:
        ap.error("--rooms must be 2..16 and --room-size 3..8 m")
    hall_w, length = 2.0, n * s
    rooms = [{"id": 0, "label": "hallway", "footprint": [[[0, 0], [length, 0], [length, hall_w], [0, hall_w]]]}]
    doors, walls, objects = [], [], []
    walls += [{"from": [0, 0], "to": [length, 0]}, {"from": [length, 0], "to": [length, hall_w + s]},
              {"from": [length, hall_w + s], "to": [0, hall_w + s]}, {"from": [0, hall_w + s], "to": [0, 0]},
              {"from": [0, hall_w], "to": [length, hall_w]}]
    # Furniture relative to a room's south-west corner (x east, y north); the same in every room.
    furniture = [
        ("bed", [2.9, 2.9, 0.3], [2.0, 1.6, 0.6], 1.5708),
        ("chest_of_drawers", [0.45, 3.6, 0.45], [0.8, 0.5, 0.9], 3.14159),
        ("table", [0.6, 1.2, 0.375], [0.8, 0.6, 0.75], 1.5708),
        ("chair", [1.2, 1.2, 0.45], [0.45, 0.45, 0.9], 0.0),
        ("tv_monitor", [2.2, 3.85, 1.1], [0.9, 0.1, 0.55], 3.14159),
        ("plant", [3.6, 0.45, 0.5], [0.4, 0.4, 1.0], 0.0),
    ]
    for i in range(n):
        x0, y0 = i * s, hall_w
        rid = i + 1
        rooms.append({"id": rid, "label": "bedroom",
                      "footprint": [[[x0, y0], [x0 + s, y0], [x0 + s, y0 + s], [x0, y0 + s]]]})
        doors.append({"a": [x0 + 1.6, y0], "b": [x0 + 2.5, y0], "room_a": 0, "room_b": rid})
        if i > 0:
            walls.append({"from": [x0, y0], "to": [x0, y0 + s]})
        for label, c, size, yaw in furniture:
            objects.append({"id": len(objects), "label": label, "center": [x0 + c[0], y0 + c[1], c[2]],
                            "size": size, "yaw": yaw, "room": rid, "add_box_shape": True})
    shapes = [
        {"type": "box", "center": [length / 2, (hall_w + s) / 2, -0.05], "size": [length + 0.1, hall_w + s + 0.1, 0.1],
         "material": {"label": "floor", "color": [160, 120, 80], "texture": "noise", "texture_scale": 0.15}},
        {"type": "box", "center": [length / 2, (hall_w + s) / 2, 2.55], "size": [length + 0.1, hall_w + s + 0.1, 0.1],
         "material": {"label": "ceiling", "color": [245, 245, 240]}},
    ]
    world = {"format": "qsg_world", "version": 1, "name": f"identical_rooms_{n}", "rooms": rooms, "doors": doors,
             "walls": walls, "objects": objects, "shapes": shapes}
    print(json.dumps(world, indent=1))


if __name__ == "__main__":
    main()
