#!/usr/bin/env python3
"""Writes a sahbench tree file (docs/tree_format.md) for an OBJ scene: a trivial median-split BVH2.

An example of bringing your own tree from another language. It reads the OBJ's triangles the way
sahbench's loader does (fan-split polygons, float32 coordinates, invalid triangles removed), hashes them
(FNV-1a 64 over their float32 bytes), builds a binary tree by splitting each node's triangles at the
median centroid along the widest axis, and writes header, nodes and references little-endian.

    python3 scripts/write_tree.py scene.obj scene.sbt
    build/release/sahbench build --scene scene.obj --builder file:scene.sbt

Only `v` and `f` lines are read (`f` corners as `i`, `i/t`, `i//n` or `i/t/n`, negative indices counting
back from the last vertex). Malformed lines are read as sahbench reads them (scenes/obj_loader.cpp): its
OBJ reader, tinyobjloader (Debian's 2.0.0rc10, which sahbench links), reads a missing or unparsable
coordinate or index as 0, and sahbench's own strict pass over the same lines then marks such a vertex
non-finite (a `v` line with fewer than 3 coordinates, or a coordinate that is not a finite float:
"banana", "nan", "1e39") and such a corner a bad index, so that their triangles are removed and counted
rather than kept at the origin. A coordinate that passes gets the value tinyobjloader's tryParseDouble
computes, which is not always the nearest float ("+-1" passes and is read as 0, "0e500" as NaN), so the
triangles and their hash are sahbench's. Should they still differ (another tinyobjloader), sahbench
refuses the tree with a message naming both scene hashes rather than measuring it on another scene.
Standard library only.
"""

import argparse
import math
import re
import struct
import sys

MAGIC = b"SAHBTREE"
VERSION = 1
FNV_OFFSET = 0xCBF29CE484222325
FNV_PRIME = 0x100000001B3
FLT_MAX = struct.unpack("<f", b"\xff\xff\x7f\x7f")[0]
MAX_LEAF = 0xFFFF  # prim_count is 16 bits


def f32(x):
    """x rounded to float32 as a C cast or a float operation rounds it: to nearest, infinity where the
    rounded value is beyond the float range (struct refuses to pack those)."""
    try:
        return struct.unpack("<f", struct.pack("<f", x))[0]
    except OverflowError:
        return math.copysign(math.inf, x)


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


# A coordinate sahbench accepts (finite_float in scenes/obj_loader.cpp): one optional '+', then what
# std::from_chars reads as a double in the general format, the whole word. "inf" and "nan" are read there
# too but are not finite, so they are left out here.
FROM_CHARS_DOUBLE = re.compile(r"-?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
# An index sahbench accepts (int_index there): one optional '+', then a from_chars int.
FROM_CHARS_INT = re.compile(r"\+?-?[0-9]+")
INT_MIN, INT_MAX = -(2**31), 2**31 - 1
# tinyobjloader's table of negative powers of ten for the first fraction digits (tryParseDouble).
POW_LUT = (1.0, 0.1, 0.01, 0.001, 0.0001, 0.00001, 0.000001, 0.0000001)


def finite_float(word):
    """Whether sahbench's strict pass accepts the coordinate: from_chars reads all of it, in range (an
    underflow to zero is out of range there, a subnormal is not) and finite as a float."""
    number = word.removeprefix("+")
    if not FROM_CHARS_DOUBLE.fullmatch(number):
        return False
    value = float(number)
    if value == 0.0 and re.search(r"[1-9]", re.split(r"[eE]", number)[0]):
        return False
    return abs(value) <= FLT_MAX


def c_pow(x, y):
    """C's pow, which gives infinity where Python's raises."""
    try:
        return x**y
    except OverflowError:
        return math.inf


def c_ldexp(x, e):
    """C's ldexp, which gives infinity where Python's raises."""
    try:
        return math.ldexp(x, e)
    except OverflowError:
        return math.copysign(math.inf, x)


def try_parse_double(word):
    """tinyobjloader's tryParseDouble (tiny_obj_loader.h), operation by operation in double, or None where
    it fails (parseReal then gives the default, 0). Only its reading of words the strict pass accepts
    matters: those decide the value of a kept vertex."""
    n, i = len(word), 0
    sign, leading_dot = 1, False
    if word[0] in "+-":
        sign = -1 if word[0] == "-" else 1
        i = 1
        leading_dot = i < n and word[i] == "."
    elif word[0] in "0123456789.":
        leading_dot = word[0] == "."
    else:
        return None
    mantissa, exponent = 0.0, 0
    if not leading_dot:
        start = i
        while i < n and word[i] in "0123456789":
            mantissa = mantissa * 10 + int(word[i])
            i += 1
        if i == start:
            return None
    if i < n and word[i] == ".":
        i += 1
        read = 1
        while i < n and word[i] in "0123456789":
            mantissa += int(word[i]) * (POW_LUT[read] if read < len(POW_LUT) else c_pow(10.0, -read))
            read += 1
            i += 1
    if i < n and word[i] in "eE":
        i += 1
        exp_sign = 1
        if i < n and word[i] in "+-":
            exp_sign = -1 if word[i] == "-" else 1
            i += 1
        elif not (i < n and word[i] in "0123456789"):
            return None
        start = i
        while i < n and word[i] in "0123456789":
            if exponent > INT_MAX // 10:
                return None
            exponent = exponent * 10 + int(word[i])
            i += 1
        exponent *= exp_sign
        if i == start:
            return None
    value = c_ldexp(mantissa * c_pow(5.0, exponent), exponent) if exponent else mantissa
    return sign * value


def vertex_index(word):
    """A face corner's vertex index as sahbench takes it: the strict pass's int, valued as tinyobjloader's
    atoi reads it ("+-2" passes the strict pass, and atoi reads 0), or 0 where the strict pass refuses it.
    0 is never a vertex."""
    index = word.split("/")[0]
    if not FROM_CHARS_INT.fullmatch(index) or not INT_MIN <= int(index.removeprefix("+")) <= INT_MAX:
        return 0
    return 0 if index.startswith("+-") else int(index)


def tinyobj_corner_count(words):
    """How many corners tinyobjloader's parseRawTriple loop reads from a face's words: one a word, except
    that a word with more slashes than i/t/n has (1/2/3/4, 1//2/3) is read as several, the next corner
    starting at the slash where the one before stopped."""
    count = 0
    for word in words:
        k = 0  # where the corner starts
        while True:
            count += 1
            k = word.find("/", k)  # after the vertex index
            if k < 0:
                break
            k += 1
            if word.startswith("/", k):  # i//n
                k = word.find("/", k + 1)
            else:  # i/t, then i/t/n
                k = word.find("/", k)
                if k >= 0:
                    k = word.find("/", k + 1)
            if k < 0:
                break
    return count


def obj_lines(data):
    """(keyword, words) of the `v` and `f` lines as tinyobjloader and sahbench's strict pass split them:
    lines end at LF, CR LF or a lone CR and at a NUL; leading blanks are skipped; a keyword is followed by
    a space or a tab; words are separated by spaces and tabs."""
    for line in re.split(r"\r\n|\r|\n", data):
        line = line.split("\0")[0].lstrip(" \t")
        if len(line) >= 2 and line[0] in "vf" and line[1] in " \t":
            rest = line[2:].strip(" \t")
            yield line[0], re.split(r"[ \t]+", rest) if rest else []


def read_obj(path):
    """The OBJ's valid triangles, in sahbench's order (scenes/obj_loader.cpp, scenes/triangle_filter.h),
    and how many were removed."""
    with open(path, "rb") as f:
        data = f.read().decode("latin-1")  # one character a byte, as the C++ reads them
    vertices, corners, removed = [], [], 0
    nan3 = (math.nan,) * 3
    for keyword, words in obj_lines(data):
        if keyword == "v":
            if len(words) >= 3 and all(finite_float(w) for w in words[:3]):
                # A word tryParseDouble fails on is parseReal's default, 0.
                values = [try_parse_double(w) for w in words[:3]]
                vertices.append(tuple(f32(0.0 if v is None else v) for v in values))
            else:
                vertices.append(nan3)
            continue
        if not words:
            continue  # no corners: tinyobjloader makes no face
        count = tinyobj_corner_count(words)
        if count < 3:
            removed += 1  # zero area by definition
            continue
        # Where the strict pass and tinyobjloader split the corners differently, every corner is bad.
        raw = [vertex_index(w) for w in words] if count == len(words) else [0] * count
        # 1-based; negative counts back from the vertices read so far; 0 is invalid (-1 here).
        face = [i - 1 if i > 0 else max(len(vertices) + i, -1) if i < 0 else -1 for i in raw]
        for k in range(1, count - 1):
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
    try:
        triangles, removed = read_obj(args.obj)
    except OSError as e:
        print(f"write_tree: {args.obj}: {e.strerror}", file=sys.stderr)
        sys.exit(2)
    if not triangles:
        sys.exit(f"{args.obj}: no valid triangles")
    nodes, refs = build_median_split(triangles, args.max_leaf)
    write_tree(args.out, nodes, refs, triangles)
    print(f"{args.out}: {len(nodes)} nodes, {len(refs)} references for {len(triangles)} triangles "
          f"({removed} removed), scene hash {scene_hash(triangles):#018x}")


if __name__ == "__main__":
    main()
