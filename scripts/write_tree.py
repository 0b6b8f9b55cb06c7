#!/usr/bin/env python3
"""Writes a sahbench tree file (docs/tree_format.md) for an OBJ scene: a trivial median-split BVH2.

An example of bringing your own tree from another language. It reads the OBJ's triangles the way
sahbench's loader does (fan-split polygons, float32 coordinates, invalid triangles removed), hashes them
(FNV-1a 64 over their float32 bytes), builds a binary tree by splitting each node's triangles at the
median centroid along the widest axis, and writes header, nodes and references little-endian.

    python3 scripts/write_tree.py scene.obj scene.sbt
    build/release/sahbench build --scene scene.obj --builder file:scene.sbt

Only `v` and `f` lines are read (`f` corners as `i`, `i/t`, `i//n` or `i/t/n`, negative indices counting
back from the last vertex). Numbers are parsed as Python floats; sahbench's OBJ parser is its own, so a
coordinate written with more digits than a float holds may round differently there, and sahbench then
refuses the tree with a message naming both scene hashes rather than measuring it on another scene.
Standard library only.
"""

import argparse
import math
import struct
import sys

MAGIC = b"SAHBTREE"
VERSION = 1
FNV_OFFSET = 0xCBF29CE484222325
FNV_PRIME = 0x100000001B3
FLT_MAX = struct.unpack("<f", b"\xff\xff\x7f\x7f")[0]
MAX_LEAF = 0xFFFF  # prim_count is 16 bits


def f32(x):
    """x rounded to float32, as sahbench's loader does: beyond the float range, infinity."""
    if math.isnan(x):
        return x
    if x > FLT_MAX:
        return math.inf
    if x < -FLT_MAX:
        return -math.inf
    return struct.unpack("<f", struct.pack("<f", x))[0]


def zero_area(a, b, c):
    """Whether (b - a) x (c - a) is exactly zero in float32 arithmetic. Each operation is done in double
    and rounded to float32, which gives the float32 result exactly (double has more than 2 * 24 + 2
    bits, Figueroa 1995), as sahbench computes it with -ffp-contract=off."""
    e1 = [f32(b[i] - a[i]) for i in range(3)]
    e2 = [f32(c[i] - a[i]) for i in range(3)]
    n = (f32(f32(e1[1] * e2[2]) - f32(e1[2] * e2[1])),
         f32(f32(e1[2] * e2[0]) - f32(e1[0] * e2[2])),
         f32(f32(e1[0] * e2[1]) - f32(e1[1] * e2[0])))
    return n == (0.0, 0.0, 0.0)


def read_obj(path):
    """The OBJ's valid triangles, in sahbench's order, and how many were removed."""
    vertices, corners, removed = [], [], 0
    with open(path, encoding="utf-8", errors="replace") as f:
        for line in f:
            tokens = line.split()
            if not tokens:
                continue
            if tokens[0] == "v":
                try:
                    vertices.append(tuple(f32(float(t)) for t in tokens[1:4]))
                except ValueError:
                    vertices.append((math.nan,) * 3)
            elif tokens[0] == "f":
                face = []
                for t in tokens[1:]:
                    try:
                        i = int(t.split("/")[0])
                    except ValueError:
                        i = 0
                    # 1-based; negative counts back from the vertices read so far; 0 is invalid.
                    face.append(i - 1 if i > 0 else len(vertices) + i if i < 0 else -1)
                if len(face) < 3:
                    removed += 1
                    continue
                for k in range(1, len(face) - 1):
                    corners.append((face[0], face[k], face[k + 1]))
    triangles = []
    for tri in corners:
        if any(i < 0 or i >= len(vertices) for i in tri):
            removed += 1
            continue
        a, b, c = (vertices[i] for i in tri)
        if not all(math.isfinite(x) for x in a + b + c) or zero_area(a, b, c):
            removed += 1
            continue
        triangles.append((a, b, c))
    return triangles, removed


def scene_hash(triangles):
    """FNV-1a 64 over every coordinate's 4 little-endian float32 bytes, triangle by triangle."""
    h = FNV_OFFSET
    for a, b, c in triangles:
        for byte in struct.pack("<9f", *a, *b, *c):
            h = ((h ^ byte) * FNV_PRIME) & 0xFFFFFFFFFFFFFFFF
    return h


def build_median_split(triangles, max_leaf):
    """A binary tree: nodes as [min xyz, max xyz, first, child_count, prim_count], and the references.
    Each inner node's two children are allocated together, so they are contiguous as the format needs."""
    boxes = [(tuple(min(v[i] for v in t) for i in range(3)), tuple(max(v[i] for v in t) for i in range(3)))
             for t in triangles]
    centres = [tuple((lo[i] + hi[i]) * 0.5 for i in range(3)) for lo, hi in boxes]
    nodes = [None]
    refs = []
    stack = [(0, list(range(len(triangles))))]  # (node index, its triangles)
    while stack:
        index, prims = stack.pop()
        lo = tuple(min(boxes[p][0][i] for p in prims) for i in range(3))
        hi = tuple(max(boxes[p][1][i] for p in prims) for i in range(3))
        if len(prims) <= max_leaf:
            nodes[index] = [lo, hi, len(refs), 0, len(prims)]
            refs.extend(prims)
            continue
        extent = [max(centres[p][i] for p in prims) - min(centres[p][i] for p in prims) for i in range(3)]
        axis = extent.index(max(extent))
        prims.sort(key=lambda p: (centres[p][axis], p))
        half = len(prims) // 2
        first = len(nodes)
        nodes.extend([None, None])
        nodes[index] = [lo, hi, first, 2, 0]
        stack.append((first, prims[:half]))
        stack.append((first + 1, prims[half:]))
    return nodes, refs


def write_tree(path, nodes, refs, triangles):
    header = MAGIC + struct.pack("<IIQQQQ", VERSION, 2, len(nodes), len(refs), len(triangles),
                                 scene_hash(triangles))
    header += bytes(64 - len(header))  # reserved
    with open(path, "wb") as f:
        f.write(header)
        for lo, hi, first, child_count, prim_count in nodes:
            f.write(struct.pack("<6fIHH", *lo, *hi, first, child_count, prim_count))
        f.write(struct.pack(f"<{len(refs)}I", *refs))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("obj", help="the scene (OBJ)")
    parser.add_argument("out", help="the tree file to write")
    parser.add_argument("--max-leaf", type=int, default=4, help="triangles per leaf at most (default 4)")
    args = parser.parse_args()
    if not 1 <= args.max_leaf <= MAX_LEAF:
        parser.error(f"--max-leaf must be in [1, {MAX_LEAF}]")
    triangles, removed = read_obj(args.obj)
    if not triangles:
        sys.exit(f"{args.obj}: no valid triangles")
    nodes, refs = build_median_split(triangles, args.max_leaf)
    write_tree(args.out, nodes, refs, triangles)
    print(f"{args.out}: {len(nodes)} nodes, {len(refs)} references for {len(triangles)} triangles "
          f"({removed} removed), scene hash {scene_hash(triangles):#018x}")


if __name__ == "__main__":
    main()
