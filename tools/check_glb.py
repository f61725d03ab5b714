#!/usr/bin/env python3
"""Load a binary glTF (.glb) written by nimbus with trimesh, an importer
independent of nimbus and of the Rust `gltf` crate, and print what it holds:
each mesh (vertices, triangles, custom vertex attributes), each node that
draws one (its world-space bounds, node transforms applied) and the totals.

Fails (exit status 1, one line on standard error) when trimesh cannot load
the file, when it holds no mesh, or when a mesh is empty or has a
non-finite vertex.

    pip install trimesh
    python3 tools/check_glb.py cloud.glb [more.glb ...]
"""

import re
import sys


def natural(name):
    """Sort key: cumulus_2 before cumulus_10."""
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", name)]


def check(path):
    import numpy as np
    import trimesh

    scene = trimesh.load(path, force="scene")
    if not scene.geometry:
        raise ValueError("no mesh")
    nodes = len(scene.graph.nodes_geometry)
    print(f"{path}: {len(scene.geometry)} meshes, {nodes} nodes drawing one")
    for name, mesh in sorted(scene.geometry.items(), key=lambda item: natural(item[0])):
        vertices = len(mesh.vertices)
        faces = len(mesh.faces)
        if vertices == 0 or faces == 0:
            raise ValueError(f"mesh {name}: {vertices} vertices, {faces} triangles")
        if not np.isfinite(mesh.vertices).all():
            raise ValueError(f"mesh {name}: a non-finite vertex")
        custom = sorted(getattr(mesh, "vertex_attributes", {}) or {})
        extra = f", attributes {' '.join(custom)}" if custom else ""
        print(f"  mesh {name}: {vertices} vertices, {faces} triangles{extra}")
    total_vertices = 0
    total_faces = 0
    for node in sorted(scene.graph.nodes_geometry, key=natural):
        transform, geometry = scene.graph[node]
        mesh = scene.geometry[geometry]
        world = trimesh.transform_points(mesh.vertices, transform)
        lo, hi = world.min(axis=0), world.max(axis=0)
        total_vertices += len(mesh.vertices)
        total_faces += len(mesh.faces)
        bounds = ", ".join(f"{a:.0f}..{b:.0f}" for a, b in zip(lo, hi))
        print(f"  node {node}: mesh {geometry}, world bounds x, y, z = {bounds} m")
    lo, hi = scene.bounds
    print(
        f"  total: {total_vertices} vertices, {total_faces} triangles placed; "
        f"scene bounds {np.round(lo).tolist()} .. {np.round(hi).tolist()} m"
    )


def main():
    if len(sys.argv) < 2:
        print("usage: check_glb.py FILE.glb [FILE.glb ...]", file=sys.stderr)
        return 2
    status = 0
    for path in sys.argv[1:]:
        try:
            check(path)
        except Exception as error:  # noqa: BLE001 - one line per failing file
            print(f"check_glb: {path}: {type(error).__name__}: {error}", file=sys.stderr)
            status = 1
    return status


if __name__ == "__main__":
    sys.exit(main())
