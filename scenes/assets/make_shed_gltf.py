#!/usr/bin/env python3
"""Writes shed.gltf: a small garden shed (2.4 m x 1.8 m, ridge 2.6 m high)
with one embedded base64 buffer, used by scenes/objects-shed.toml and the
glTF loader's tests. Run from this directory: python3 make_shed_gltf.py

glTF 2.0 frame: +Y up, metres, counter-clockwise front faces. The shed's
origin is the centre of its floor; its door faces +Z. It exercises what the
loader reads: node transforms (a parent node and translated children),
several meshes and materials, u16 indices, and a primitive without normals
(the roof sheets, which get flat normals).
"""
import base64, json, struct

W, D, H = 2.4, 1.8, 2.0        # walls: width (x), depth (z), height (y), m
RIDGE, OVER = 0.6, 0.15         # ridge above the eaves, roof overhang, m


def box(cx, cy, cz, sx, sy, sz):
    """24 vertices (flat normals) and 36 indices of a box, CCW from outside."""
    faces = [((1, 0, 0), (0, 1, 0), (0, 0, 1)), ((-1, 0, 0), (0, 0, 1), (0, 1, 0)),
             ((0, 1, 0), (0, 0, 1), (1, 0, 0)), ((0, -1, 0), (1, 0, 0), (0, 0, 1)),
             ((0, 0, 1), (1, 0, 0), (0, 1, 0)), ((0, 0, -1), (0, 1, 0), (1, 0, 0))]
    h = (sx / 2, sy / 2, sz / 2)
    pos, nor, idx = [], [], []
    for n, u, v in faces:
        base = len(pos)
        for su, sv in [(-1, -1), (1, -1), (1, 1), (-1, 1)]:
            pos.append(tuple((cx, cy, cz)[k] + (n[k] + su * u[k] + sv * v[k]) * h[k] for k in range(3)))
            nor.append(n)
        idx += [base, base + 1, base + 2, base, base + 2, base + 3]
    return pos, nor, idx


# Mesh 0: the walls (a box) and the two gable triangles, with normals.
pos, nor, idx = box(0, H / 2, 0, W, H, D)
for sx in (1, -1):  # gable ends at x = +-W/2, facing +-X
    x = sx * W / 2
    tri = [(x, H, D / 2), (x, H, -D / 2), (x, H + RIDGE, 0)]
    if sx < 0:
        tri = [tri[0], tri[2], tri[1]]
    base = len(pos)
    pos += tri
    nor += [(sx, 0, 0)] * 3
    idx += [base, base + 1, base + 2]
body = (pos, nor, idx)

# Mesh 1: the two roof sheets, in the roof node's frame (origin at the eaves'
# height), without normals.
half = W / 2 + OVER
eave_z = D / 2 + OVER
eave_y = -RIDGE * OVER / (D / 2)  # the slope continues past the walls
roof_pos = [(-half, eave_y, eave_z), (half, eave_y, eave_z), (half, RIDGE, 0), (-half, RIDGE, 0),
            (half, eave_y, -eave_z), (-half, eave_y, -eave_z), (-half, RIDGE, 0), (half, RIDGE, 0)]
roof_idx = [0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7]
roof = (roof_pos, None, roof_idx)

# Mesh 2: the door, a thin box in the door node's frame.
door = box(0, 0, 0, 0.8, 1.75, 0.04)

bin_ = bytearray()
views, accessors = [], []


def add(values, fmt, count, target, acc_type, comp, minmax=False):
    while len(bin_) % 4:
        bin_.append(0)
    offset = len(bin_)
    for v in values:
        bin_.extend(struct.pack(fmt, *v) if isinstance(v, tuple) else struct.pack(fmt, v))
    views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(bin_) - offset, "target": target})
    acc = {"bufferView": len(views) - 1, "componentType": comp, "count": count, "type": acc_type}
    if minmax:
        acc["min"] = [min(v[k] for v in values) for k in range(3)]
        acc["max"] = [max(v[k] for v in values) for k in range(3)]
    accessors.append(acc)
    return len(accessors) - 1


meshes = []
for name, (p, n, i), material in [("walls", body, 0), ("roof", roof, 1), ("door", door, 2)]:
    attributes = {"POSITION": add(p, "<3f", len(p), 34962, "VEC3", 5126, True)}
    if n is not None:
        attributes["NORMAL"] = add(n, "<3f", len(n), 34962, "VEC3", 5126)
    indices = add(i, "<H", len(i), 34963, "SCALAR", 5123)
    meshes.append({"name": name, "primitives": [
        {"attributes": attributes, "indices": indices, "material": material}]})

gltf = {
    "asset": {"version": "2.0", "generator": "nimbus scenes/assets/make_shed_gltf.py"},
    "scene": 0,
    "scenes": [{"name": "shed", "nodes": [0]}],
    "nodes": [
        {"name": "shed", "children": [1, 2, 3]},
        {"name": "walls", "mesh": 0},
        {"name": "roof", "mesh": 1, "translation": [0, H, 0]},
        {"name": "door", "mesh": 2, "translation": [0.3, 0.875, D / 2 + 0.02]},
    ],
    "meshes": meshes,
    "materials": [
        {"name": "weathered wood", "pbrMetallicRoughness": {"baseColorFactor": [0.30, 0.20, 0.12, 1], "metallicFactor": 0}},
        {"name": "red roofing felt", "pbrMetallicRoughness": {"baseColorFactor": [0.22, 0.06, 0.05, 1], "metallicFactor": 0}},
        {"name": "painted door", "pbrMetallicRoughness": {"baseColorFactor": [0.10, 0.20, 0.12, 1], "metallicFactor": 0}},
    ],
    "buffers": [{"byteLength": len(bin_),
                 "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(bin_)).decode()}],
    "bufferViews": views,
    "accessors": accessors,
}
with open("shed.gltf", "w") as f:
    json.dump(gltf, f, separators=(",", ":"))
    f.write("\n")
