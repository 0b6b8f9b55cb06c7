#!/usr/bin/env python3
"""scripts/write_tree.py end to end: it writes a tree file for an OBJ (with quads, negative indices and
invalid triangles that sahbench removes), and sahbench reads it as the `file` builder: `build` validates
it, a config run (path relative to the config) traces it with no mismatch against brute force, and the
same tree for a moved vertex is refused as another scene's. On an OBJ of malformed lines (short and
unparsable vertices, faces with missing, zero, unparsable or too few indices) the script keeps and removes
the triangles sahbench does, so that sahbench accepts its tree; a missing OBJ is an exit 2, not a
traceback. The script runs as an executable, as the README calls it.

    test_write_tree.py scripts/write_tree.py path/to/sahbench
"""

import csv
import os
import random
import subprocess
import sys
import tempfile


def write_obj(path, nudge=False):
    rng = random.Random(5)
    lines = []
    vertices = 0
    # Random small triangles on a 1/16 grid (exact in float32 whatever the parser), some of them quads.
    for k in range(150):
        base = [rng.randint(-160, 160) / 16 for _ in range(3)]
        corners = 4 if k % 5 == 0 else 3
        for c in range(corners):
            v = [base[i] + rng.randint(-16, 16) / 16 for i in range(3)]
            if nudge and k == 42 and c == 1:
                v[0] += 0.5
            lines.append("v %r %r %r" % tuple(v))
        vertices += corners
        if k % 3 == 0:  # negative indices, counting back
            lines.append("f " + " ".join(str(-corners + c) for c in range(corners)))
        else:
            lines.append("f " + " ".join(f"{vertices - corners + c + 1}/1/1" for c in range(corners)))
    # Removed by sahbench and by the script alike: collinear, repeated vertex, index out of range.
    lines += ["v 0 0 0", "v 1 1 1", "v 2 2 2", f"f {vertices + 1} {vertices + 2} {vertices + 3}",
              f"f {vertices + 1} {vertices + 1} {vertices + 2}", f"f 1 2 {vertices + 99}"]
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


# Malformed lines, each with what sahbench makes of it (scenes/obj_loader.cpp): 8 triangles kept, 15 removed.
MALFORMED = """\
v 0 0 0
v 1 0 0
v 0 1 0
v 1 1 0
v 2 2
v 1 banana 3
v +-1 0 1
v 0e500 0 0
v 0 0 1e-400
f 1 2 3
f 2 4 3
# Vertex 5 has 2 coordinates, 6 a word, 8 reads as NaN and 9 underflows: non-finite, removed.
f 1 2 5
f 1 6 3
f 2 3 8
f 1 2 9
# "+-1" passes sahbench's strict pass and tinyobjloader reads it as 0: vertex 7 is (0, 0, 1), kept.
f 1 2 7
# A vertex past the end, before the first, 0, a word, "+-1" (0 to atoi): bad indices.
f 1 2 99
f -1 -2 -99
f 0 1 2
f 1 x 3
f +-1 2 3
# Fewer than 3 corners: zero area.
f 1 2
# tinyobjloader reads 1/1/1/1 as two corners, so no corner of the face is trusted: 2 bad indices.
f 1/1/1/1 2 3
# Kept: "+N" indices and negative ones from the last vertex.
f +1 +2 +4
f -9 -8 -7
# Fans: (2 3 4) kept, (2 4 5) non-finite, (2 5 99999999999) a bad index, beyond int; (1 2 3) and
# (1 3 4) kept, (1 4 5) non-finite.
f 2 3 4 5 99999999999
f 1 2 3 4 5
"""


def run(cmd, expect_rc=0):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != expect_rc:
        sys.exit(f"{' '.join(cmd)}: exit {p.returncode}, expected {expect_rc}\n{p.stdout}\n{p.stderr}")
    return p


def check_malformed(script, sahbench, tmp):
    """The malformed OBJ: the script, run as the executable its shebang names, keeps sahbench's triangles
    and sahbench accepts the tree; a missing OBJ is named in an exit 2."""
    obj = os.path.join(tmp, "malformed.obj")
    with open(obj, "w") as f:
        f.write(MALFORMED)
    tree = os.path.join(tmp, "malformed.sbt")
    p = run([script, obj, tree])
    assert "for 8 triangles (15 removed)" in p.stdout and "Traceback" not in p.stderr, p.stdout + p.stderr
    built = run([sahbench, "build", "--scene", obj, "--builder", "file:" + tree, "--reps", "1", "--warmup", "0"])
    assert "8 triangles, 15 removed" in built.stdout, built.stdout
    rows = [line for line in built.stdout.splitlines() if line.strip().startswith("1 ")]
    assert len(rows) == 1 and rows[0].endswith(" ok"), built.stdout

    missing = os.path.join(tmp, "none.obj")
    p = run([sys.executable, script, missing, tree], expect_rc=2)
    assert missing in p.stderr and "Traceback" not in p.stderr, p.stderr


def main():
    script, sahbench = sys.argv[1], sys.argv[2]
    with tempfile.TemporaryDirectory() as tmp:
        check_malformed(script, sahbench, tmp)
        obj = os.path.join(tmp, "scene.obj")
        write_obj(obj)
        os.makedirs(os.path.join(tmp, "trees"))
        tree = os.path.join(tmp, "trees", "median.sbt")
        out = run([sys.executable, script, obj, tree]).stdout
        # 150 faces, 30 of them quads: 180 triangles, 3 removed.
        assert "for 180 triangles (3 removed)" in out, out

        built = run([sahbench, "build", "--scene", obj, "--builder", "file:" + tree, "--builder", "binned_sah",
                     "--reps", "1", "--warmup", "0"]).stdout
        assert "180 triangles, 3 removed" in built, built
        rows = [line for line in built.splitlines() if line.strip().startswith("1 ")]
        assert len(rows) == 2 and all(r.endswith(" ok") for r in rows), built

        # A config beside the trees folder, naming the tree relative to itself; run from elsewhere.
        config = os.path.join(tmp, "byot.toml")
        result = os.path.join(tmp, "byot.csv")
        with open(config, "w") as f:
            f.write(f'[experiment]\nname = "byot"\nscenes = ["{obj}"]\nlayouts = ["bvh2", "bvh2_packed"]\n'
                    'reference = "brute_force"\n'
                    "[repetitions]\nbuild = 1\nbuild_warmup = 0\ntrace = 1\ntrace_warmup = 0\n"
                    '[[builder]]\nname = "file"\npath = "trees/median.sbt"\n'
                    '[[builder]]\nname = "embree"\n'
                    '[[ray_set]]\nkind = "primary"\nwidth = 32\nheight = 32\n'
                    '[[ray_set]]\nkind = "random"\ncount = 2000\n')
        run([sahbench, "run", config, "--output", result])
        with open(result, newline="") as f:
            table = list(csv.DictReader(f))
        ours = [r for r in table if r["builder"] == "file"]
        assert len(ours) == 4, table  # 2 layouts x 2 ray sets
        assert any(r["builder"] == "embree" for r in table), table
        for r in table:
            assert r["mismatches"] == "0", r
        assert all(r["builder_params"].startswith("path=" + os.path.basename(tree) + ";path_hash=0x")
                   for r in ours), ours[0]["builder_params"]

        # The same tree on a scene with one vertex moved: refused, naming both scenes.
        write_obj(obj, nudge=True)
        err = run([sahbench, "build", "--scene", obj, "--builder", "file:" + tree, "--reps", "1"],
                  expect_rc=2).stderr
        assert "was built for a scene with hash" in err and "this scene has hash" in err, err
    print("write_tree.py: tree written, validated and traced with no mismatches; another scene refused; "
          "malformed lines read as sahbench reads them")


if __name__ == "__main__":
    main()
