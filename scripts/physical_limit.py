#!/usr/bin/python3
"""How close each kernel comes to the cost its own counts imply: the physical limit of a cell.

    scripts/physical_limit.py RESULTS.csv BENCH.json [--threads N] [--run RUN_ID]

BENCH.json is the micro-benchmarks of the same build on the same machine, as Google Benchmark writes them:

    build/release/bench/sahbench_bench --benchmark_filter='node_visit|ray_triangle' \\
        --benchmark_format=json > bench.json

For every row of ours with counts (not Embree's, which has no counting kernel, and not packet rows, whose
rays share node tests), the bound is the time per ray of its work if every node test and every triangle
test ran at the throughput the micro-benchmarks measure with their data in cache:

    bound = (nodes_per_ray - leaves_per_ray) * t_node + prims_per_ray * t_triangle

with t_node one node visit of the row's layout, box test and ISA (all of a node's children at once), and
t_triangle one triangle of its triangle test (one lane of a 4-triangle block for bvh4/bvh8). The measured
time per ray is threads / rays per second, per core. bound / measured is the share of the limit reached:
1 would be a kernel that waits on nothing but its arithmetic; what is missing is memory latency, branch
mispredictions and the loop around the tests.

Where the run has Embree medium one ray at a time (embree_1) on the same scene, thread count and ray set,
in the mode `sahbench report` compares the row with (robust for our exact kernels: the watertight
triangle test and the robust box test; its default mode for the others), the last columns are Embree's
measured time per ray and the ceiling: Embree's time over our bound, the ratio to Embree 1-ray that the
row would reach at its bound. A ceiling below a target says that no better loop reaches it: the target
needs fewer tests per ray (another tree) or cheaper tests.

A CSV that holds several runs (a resumed or repeated `sahbench run`) gives the rows of its latest run,
as `sahbench report` does, or of `--run`. A builder whose rows differ in parameters is labelled with those
that differ (binned_sah bins=8, binned_sah bins=32).

Exits 2 with a message when a file lacks what is needed, when --threads is not a positive count, and
when no row is left to price (the message says which filter left none) rather than print an empty
table.
"""

import argparse
import csv
import json
import re
import sys


def fail(message):
    print(f"physical_limit: {message}", file=sys.stderr)
    sys.exit(2)


def parse_layout(text):
    """(name, {option: value}) of a layout spec such as bvh8:tri=mtn,box=fma."""
    name, _, rest = text.partition(":")
    options = dict(item.split("=", 1) for item in rest.split(",") if "=" in item)
    return name, options


def builder_label(row):
    """The builder, with the builder a pass starts from: wide_collapse[source=reinsert]."""
    source = re.match(r"(?:.*?;)?source=([a-z_0-9]+)", row.get("builder_params", ""))
    return f"{row['builder']}[source={source.group(1)}]" if source else row["builder"]


def split_params(text):
    """{key: value} of a builder_params text, split at the semicolons outside parentheses (a pass's
    source=reinsert(source=binned_sah(bins=32)) is one value)."""
    items, depth, start = [], 0, 0
    for i, ch in enumerate(text):
        depth += ch == "("
        depth -= ch == ")"
        if ch == ";" and depth == 0:
            items.append(text[start:i])
            start = i + 1
    items.append(text[start:])
    return dict(item.split("=", 1) for item in items if "=" in item)


def labels(rows):
    """Each row's builder label, with the parameters that differ between the rows of its builder."""
    params = [split_params(row.get("builder_params", "")) for row in rows]
    varying = {}
    for row, p in zip(rows, params):
        for other_row, q in zip(rows, params):
            if row["builder"] == other_row["builder"]:
                varying.setdefault(row["builder"], set()).update(k for k in p.keys() | q.keys() if p.get(k) != q.get(k))
    # builder_label names the source; its parameters are named too where rows of the same source differ.
    def source_name(p):
        return p.get("source", "").split("(")[0]

    def nested(row, p):
        return any(row["builder"] == other["builder"] and source_name(p) == source_name(q)
                   and p.get("source") != q.get("source") for other, q in zip(rows, params))

    out = []
    for row, p in zip(rows, params):
        keys = [k for k in p if k in varying.get(row["builder"], ()) and (k != "source" or nested(row, p))]
        extra = " ".join(f"{k}={p[k]}" for k in keys)
        out.append(builder_label(row) + (" " + extra if extra else ""))
    return out


def benchmark_names(row):
    """The node and triangle benchmarks of a row, or None for a row without a bound."""
    name, options = parse_layout(row["layout"])
    if options.get("packet", "1") != "1":
        return None
    box = options.get("box", "robust")
    tri = options.get("tri", "watertight")
    if name in ("bvh2", "bvh2_packed"):
        # Both binary walks test a leaf's triangles four at a time (traversal/triangle_lanes.h, on
        # x86-64; mtn only where the CPU has FMA, and a bench built without it names its lanes as
        # missing). The benchmark reads the four one after the other and refines watertight hits'
        # distances: bvh2 gathers them through references, and watertight any-hit rows refine nothing,
        # so their bound is a little low and high respectively. The common-format node visit is
        # benchmarked with the robust box test only; other box tests' rows are named as missing rather
        # than priced with it.
        test = f"lanes4/{tri}"
        return f"node_visit/{name}/scalar/{box}", f"ray_triangle/{test}"
    if name in ("bvh4", "bvh8"):
        isa = row["isa"]
        return f"node_visit/{name}/{isa}/{box}", f"ray_triangle/block4/{isa}/{tri}"
    return None


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("results")
    parser.add_argument("bench")
    parser.add_argument("--threads", type=int, help="only rows of this thread count")
    parser.add_argument("--run", help="the rows of this run_id (default: the CSV's latest run)")
    args = parser.parse_args()
    if args.threads is not None and args.threads < 1:
        parser.error(f"--threads {args.threads}: a thread count is 1 or more")

    try:
        with open(args.bench) as f:
            bench = json.load(f)
    except (OSError, json.JSONDecodeError) as e:
        fail(f"{args.bench}: {e}")
    ns_per_item = {}
    for b in bench.get("benchmarks", []):
        if b.get("items_per_second"):
            ns_per_item[b["name"]] = 1e9 / b["items_per_second"]
    if not ns_per_item:
        fail(f"{args.bench}: no benchmark with items_per_second (run sahbench_bench with --benchmark_format=json)")

    try:
        with open(args.results, newline="") as f:
            rows = list(csv.DictReader(f))
    except OSError as e:
        fail(f"{args.results}: {e}")
    needed = ["layout", "isa", "threads", "nodes_per_ray", "leaves_per_ray", "prims_per_ray", "trace_mrays_median"]
    if rows and any(c not in rows[0] for c in needed):
        missing = [c for c in needed if c not in rows[0]]
        fail(f"{args.results}: no column {', '.join(missing)} (a CSV of this version of sahbench run is needed)")

    if rows and "run_id" in rows[0]:
        runs = list(dict.fromkeys(row["run_id"] for row in rows))
        run = args.run or rows[-1]["run_id"]  # rows are appended as cells finish: the last is the latest run's
        if run not in runs:
            fail(f"{args.results}: no run {run} (its runs: {', '.join(runs)})")
        rows = [row for row in rows if row["run_id"] == run]
        others = f"; {len(runs) - 1} other run(s) in the file, --run RUN_ID for one" if len(runs) > 1 else ""
        heading = f"Run {run}{others}.\n"
        where = f"{args.results} (run {run})"
    elif args.run:
        fail(f"{args.results}: no run_id column to choose --run {args.run} by")
    else:
        heading, where = None, args.results
    if not rows:
        fail(f"{where}: no rows")
    if args.threads is not None:
        counts = sorted({int(row["threads"]) for row in rows})
        if args.threads not in counts:
            fail(f"{where}: no row of --threads {args.threads} (its thread counts: {', '.join(map(str, counts))})")

    # Embree medium's one-ray rows by (scene, threads, ray set, robust).
    embree = {}
    for row in rows:
        if row.get("builder") == "embree" and row["layout"] == "embree_1" and row["trace_mrays_median"]:
            params = split_params(row.get("builder_params", ""))
            if params.get("quality", "medium") == "medium":
                key = (row["scene"], row["threads"], row["ray_set"], params.get("robust", "0") == "1")
                embree[key] = 1000.0 * int(row["threads"]) / float(row["trace_mrays_median"])

    # The table is printed only once it has a row; the rows left out are counted by reason for the message
    # that replaces an empty table.
    table, missing_bench = [], set()
    uncounted = unpriced = unbenched = 0
    for row, label in zip(rows, labels(rows)):
        if args.threads is not None and int(row["threads"]) != args.threads:
            continue
        if not row["nodes_per_ray"] or not row["leaves_per_ray"] or not row["trace_mrays_median"]:
            uncounted += 1
            continue
        names = benchmark_names(row)
        if names is None:
            unpriced += 1
            continue
        if any(n not in ns_per_item for n in names):
            missing_bench.update(n for n in names if n not in ns_per_item)
            unbenched += 1
            continue
        nodes, leaves = float(row["nodes_per_ray"]), float(row["leaves_per_ray"])
        prims = float(row["prims_per_ray"])
        bound = (nodes - leaves) * ns_per_item[names[0]] + prims * ns_per_item[names[1]]
        measured = 1000.0 * int(row["threads"]) / float(row["trace_mrays_median"])
        _, options = parse_layout(row["layout"])
        exact = options.get("tri", "watertight") == "watertight" and options.get("box", "robust") == "robust"
        anchor = embree.get((row["scene"], row["threads"], row["ray_set"], exact))
        versus = f"{anchor:.0f} | {anchor / bound:.2f}" if anchor else "- | -"
        table.append(f"| {row['scene']} | {label} | {row['layout']} | {row['threads']} | {row['ray_set']} | "
                     f"{nodes - leaves:.1f} + {leaves:.1f} | {prims:.1f} | {bound:.0f} | {measured:.0f} | "
                     f"{bound / measured:.2f} | {versus} |")
    if not table:
        threads = f" of --threads {args.threads}" if args.threads is not None else ""
        reasons = [f"{uncounted} without nodes_per_ray, leaves_per_ray or trace_mrays_median (Embree's rows have "
                   "no counts)" if uncounted else "",
                   f"{unpriced} of a layout without a bound (packets, Embree's)" if unpriced else "",
                   f"{unbenched} whose benchmarks {args.bench} lacks: {', '.join(sorted(missing_bench))}"
                   if unbenched else ""]
        fail(f"{where}: no row{threads} to price: {'; '.join(r for r in reasons if r)}")

    if heading:
        print(heading)
    print("| scene | builder | layout | threads | ray set | inner + leaves | prims | bound ns | measured ns | "
          "bound / measured | Embree 1-ray ns | ceiling |")
    print("| --- | --- | --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    print("\n".join(table))
    if missing_bench:
        print(f"\nNo figure in {args.bench} for: {', '.join(sorted(missing_bench))} (their rows are left out).")


if __name__ == "__main__":
    main()
