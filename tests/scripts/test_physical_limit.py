#!/usr/bin/python3
"""scripts/physical_limit.py on a hand-made CSV and benchmark JSON: the bound of each row from its counts
and the benchmarks of its layout, box test, triangle test and ISA; Embree and packet rows left out; a row
whose benchmark is missing named; the ceiling against Embree medium 1-ray in the row's mode; exit 2 for
a CSV without leaves_per_ray, for --threads 0 or below, for a thread count the CSV lacks (naming those it
has) and for filters that leave no row to price, with no empty table. The script runs as an executable,
as the README calls it.

    test_physical_limit.py PATH/TO/physical_limit.py
"""

import csv
import json
import subprocess
import sys
import tempfile
from pathlib import Path

failures = []


def check(condition, message):
    if not condition:
        failures.append(message)
        print(f"FAIL: {message}", file=sys.stderr)


COLUMNS = ["scene", "builder", "layout", "isa", "threads", "ray_set", "nodes_per_ray", "leaves_per_ray",
           "prims_per_ray", "trace_mrays_median", "builder_params", "run_id"]
# A pass's row names the builder it starts from, the outermost source only.
PASS = "arity=8;source=reinsert(source=binned_sah(bins=32));c_trav=1"
PLAIN = "arity=8;source=binned_sah;c_trav=1"
ROWS = [
    # An earlier run in the same file (a resumed output): left out unless asked for with --run.
    ["s", "binned_sah", "bvh2_packed:tri=mt,box=fast", "scalar", "1", "shadow", "40", "10", "5", "2", "bins=8", "r1"],
    # 10 inner nodes at 2 ns and 8 triangle lanes at 1 ns: 28 ns against 1 / 20 Mrays/s = 50 ns.
    ["s", "wide_collapse", "bvh8", "avx2", "1", "primary", "14", "4", "8", "20", PLAIN, "r2"],
    # Two threads: 2 / 20 Mrays/s = 100 ns per ray per core.
    ["s", "wide_collapse", "bvh8", "avx2", "2", "primary", "14", "4", "8", "20", PASS, "r2"],
    # bvh2_packed with the fast box test and Möller-Trumbore: 30 * 4 + 5 * 3 = 135 ns against 250 ns.
    ["s", "binned_sah", "bvh2_packed:tri=mt,box=fast", "scalar", "1", "shadow", "40", "10", "5", "4", "bins=32",
     "r2"],
    # bvh2_packed's watertight leaves are priced by the four-lane test: 10 * 5 + 4 * 1 = 54 ns.
    ["s", "binned_sah", "bvh2_packed", "scalar", "1", "primary", "12", "2", "4", "10", "bins=32", "r2"],
    # So are bvh2's: 10 * 8 + 4 * 1 = 84 ns against 1 / 5 Mrays/s = 200 ns.
    ["s", "binned_sah", "bvh2", "scalar", "1", "primary", "12", "2", "4", "5", "bins=32", "r2"],
    # The same builder with other parameters: each row names the parameter that differs.
    ["s", "binned_sah", "bvh2_packed:tri=mt,box=fast", "scalar", "1", "shadow", "40", "10", "5", "5", "bins=8", "r2"],
    # Embree medium one ray at a time: its default mode (30 and 10 Mrays/s) is the anchor of the fast
    # variants, its robust mode (25 Mrays/s: 40 ns) of the exact default kernels; low quality is none.
    ["s", "embree", "embree_1", "avx2", "1", "primary", "", "", "", "30", "", "r2"],
    ["s", "embree", "embree_1", "avx2", "1", "primary", "", "", "", "25", "quality=medium;robust=1", "r2"],
    ["s", "embree", "embree_1", "avx2", "1", "shadow", "", "", "", "10", "quality=medium", "r2"],
    ["s", "embree", "embree_1", "avx2", "1", "shadow", "", "", "", "50", "quality=low", "r2"],
    ["s", "wide_collapse", "bvh8:packet=8", "avx2", "1", "primary", "14", "4", "8", "25", PLAIN, "r2"],
    ["s", "wide_collapse", "bvh8:tri=mtn", "avx512", "1", "primary", "14", "4", "8", "25", PLAIN, "r2"],
    # The same pass over another source tree: named by the source's parameters, which differ.
    ["s", "wide_collapse", "bvh8", "avx2", "2", "primary", "14", "4", "8", "10",
     "arity=8;source=reinsert(source=binned_sah(bins=8));c_trav=1", "r2"],
]
BENCH = {"benchmarks": [
    {"name": "node_visit/bvh8/avx2/robust", "items_per_second": 5e8},
    {"name": "ray_triangle/block4/avx2/watertight", "items_per_second": 1e9},
    {"name": "node_visit/bvh2_packed/scalar/fast", "items_per_second": 2.5e8},
    {"name": "ray_triangle/lanes4/mt", "items_per_second": 1e9 / 3},
    {"name": "node_visit/bvh2_packed/scalar/robust", "items_per_second": 2e8},
    {"name": "ray_triangle/lanes4/watertight", "items_per_second": 1e9},
    {"name": "node_visit/bvh2/scalar/robust", "items_per_second": 1.25e8},
]}


def main():
    script = sys.argv[1]
    with tempfile.TemporaryDirectory() as tmp:
        results, bench = Path(tmp) / "r.csv", Path(tmp) / "b.json"
        with results.open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow(COLUMNS)
            w.writerows(ROWS)
        bench.write_text(json.dumps(BENCH))
        # Run as the README writes it: the script itself, through its shebang.
        out = subprocess.run([script, str(results), str(bench)], capture_output=True, text=True)
        check(out.returncode == 0, f"exit {out.returncode}: {out.stderr}")
        text = out.stdout
        # The ceiling: Embree robust's 40 ns over the exact row's bound of 28 ns.
        check("| s | wide_collapse[source=binned_sah] | bvh8 | 1 | primary | 10.0 + 4.0 | 8.0 | 28 | 50 | 0.56 | "
              "40 | 1.43 |" in text, text)
        # A fast variant against Embree's default mode: 100 ns over 135.
        check("| 135 | 250 | 0.54 | 100 | 0.74 |" in text, text)
        check("| s | binned_sah bins=32 | bvh2_packed | 1 | primary | 10.0 + 2.0 | 4.0 | 54 | 100 | 0.54 | 40 | 0.74 |"
              in text, text)
        check("| s | binned_sah bins=32 | bvh2 | 1 | primary | 10.0 + 2.0 | 4.0 | 84 | 200 | 0.42 | 40 | 0.48 |" in text,
              text)
        # No Embree row of that thread count: no ceiling.
        check("| 28 | 100 | 0.28 | - | - |" in text, text)
        check("| s | wide_collapse[source=reinsert] source=reinsert(source=binned_sah(bins=32)) | bvh8 | 2 | primary | "
              "10.0 + 4.0 | 8.0 | 28 | 100 | 0.28 |" in text, text)
        check("| s | wide_collapse[source=reinsert] source=reinsert(source=binned_sah(bins=8)) | bvh8 | 2 | primary | "
              "10.0 + 4.0 | 8.0 | 28 | 200 | 0.14 |" in text, text)
        check("| s | binned_sah bins=32 | bvh2_packed:tri=mt,box=fast | 1 | shadow | 30.0 + 10.0 | 5.0 | 135 | 250 | "
              "0.54 |" in text, text)
        check("| s | binned_sah bins=8 | bvh2_packed:tri=mt,box=fast | 1 | shadow | 30.0 + 10.0 | 5.0 | 135 | 200 | "
              "0.68 |" in text, text)
        check(text.startswith("Run r2; 1 other run(s) in the file") and "| 500 |" not in text,
              f"the latest run only, by default: {text}")
        earlier = subprocess.run([sys.executable, script, str(results), str(bench), "--run", "r1"],
                                 capture_output=True, text=True)
        check("| s | binned_sah | bvh2_packed:tri=mt,box=fast | 1 | shadow | 30.0 + 10.0 | 5.0 | 135 | 500 | 0.27 |"
              in earlier.stdout and "| 250 |" not in earlier.stdout, f"--run r1: {earlier.stdout}")
        unknown = subprocess.run([sys.executable, script, str(results), str(bench), "--run", "r9"],
                                 capture_output=True, text=True)
        check(unknown.returncode == 2 and "no run r9 (its runs: r1, r2)" in unknown.stderr, unknown.stderr)
        check("embree_1" not in text and "packet=8" not in text, text)
        check("No figure in" in text and "node_visit/bvh8/avx512/robust" in text
              and "ray_triangle/block4/avx512/mtn" in text, text)
        only = subprocess.run([sys.executable, script, str(results), str(bench), "--threads", "2"],
                              capture_output=True, text=True)
        check("| 1 | primary" not in only.stdout and "| 2 | primary" in only.stdout, only.stdout)
        for threads in ("0", "-1"):
            refused = subprocess.run([sys.executable, script, str(results), str(bench), "--threads", threads],
                                     capture_output=True, text=True)
            check(refused.returncode == 2 and f"--threads {threads}" in refused.stderr and not refused.stdout,
                  f"--threads {threads}: exit {refused.returncode}: {refused.stdout}{refused.stderr}")
        absent = subprocess.run([sys.executable, script, str(results), str(bench), "--threads", "3"],
                                capture_output=True, text=True)
        check(absent.returncode == 2 and "no row of --threads 3 (its thread counts: 1, 2)" in absent.stderr
              and "| scene |" not in absent.stdout, f"--threads 3: exit {absent.returncode}: {absent.stderr}")
        # Run r1 has 1-thread rows only.
        absent = subprocess.run([sys.executable, script, str(results), str(bench), "--run", "r1", "--threads", "2"],
                                capture_output=True, text=True)
        check(absent.returncode == 2 and "(run r1): no row of --threads 2 (its thread counts: 1)" in absent.stderr,
              f"--run r1 --threads 2: exit {absent.returncode}: {absent.stderr}")

        # Rows, but none to price: Embree's and a packet row, or rows whose benchmarks are all missing.
        unpriced = Path(tmp) / "unpriced.csv"
        with unpriced.open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow(COLUMNS)
            w.writerows(row for row in ROWS if row[2] in ("embree_1", "bvh8:packet=8", "bvh8:tri=mtn"))
        none = subprocess.run([sys.executable, script, str(unpriced), str(bench)], capture_output=True, text=True)
        check(none.returncode == 2 and "no row to price" in none.stderr and "4 without nodes_per_ray" in none.stderr
              and "1 of a layout without a bound" in none.stderr and "ray_triangle/block4/avx512/mtn" in none.stderr
              and "| scene |" not in none.stdout,
              f"no row to price: exit {none.returncode}: {none.stdout}{none.stderr}")
        empty = Path(tmp) / "empty.csv"
        empty.write_text(",".join(COLUMNS) + "\n")
        none = subprocess.run([sys.executable, script, str(empty), str(bench)], capture_output=True, text=True)
        check(none.returncode == 2 and "no rows" in none.stderr and not none.stdout,
              f"a CSV without rows: exit {none.returncode}: {none.stdout}{none.stderr}")

        old = Path(tmp) / "old.csv"
        old.write_text("scene,layout,isa,threads,ray_set,nodes_per_ray,prims_per_ray,trace_mrays_median\n"
                       "s,bvh8,avx2,1,primary,14,8,20\n")
        bad = subprocess.run([sys.executable, script, str(old), str(bench)], capture_output=True, text=True)
        check(bad.returncode == 2 and "leaves_per_ray" in bad.stderr, f"{bad.returncode}: {bad.stderr}")
        missing = subprocess.run([sys.executable, script, str(results), str(Path(tmp) / "none.json")],
                                 capture_output=True, text=True)
        check(missing.returncode == 2 and "none.json" in missing.stderr, f"{missing.returncode}: {missing.stderr}")
    if failures:
        sys.exit(1)
    print("physical_limit.py: all checks passed")


if __name__ == "__main__":
    main()
