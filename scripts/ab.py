#!/usr/bin/python3
"""Interleaved A/B of sahbench builds on one experiment config: did a change make things faster?

    scripts/ab.py [--rounds N] [--only TEXT] CONFIG BUILD_A BUILD_B [BUILD_C ...]

For example, a build of main against a build of a branch, both kept outside the build tree:

    cp build/release/sahbench /tmp/sahbench-main     # on main
    cp build/release/sahbench /tmp/sahbench-branch   # on the branch
    scripts/ab.py --rounds 4 configs/wide.toml /tmp/sahbench-main /tmp/sahbench-branch

Each round runs every build once on CONFIG (`BUILD run CONFIG --output ...`), in turn, reversing the
order every other round so that neither build always runs first on a machine that warms up or slows
down. Every run writes its own CSV in a temporary folder, so the config's output is not touched.

Timings on a shared machine vary by 10-25% between runs, but the ratio of our figure to Embree's in the
same run holds much better. So for each cell (scene, builder and parameters, layout, threads, ray set)
the script prints, per build, the median over rounds of:
- trace cells: our rays/second over Embree medium's `embree_1` (rtcIntersect1 / rtcOccluded1) on the
  same rays in the same run: above 1 is faster than Embree;
- build cells: Embree medium's build time over ours, the same way round: above 1 is faster.
and, for each build after the first, the change of that median against the first build's.

Needs pandas. Exits 1 with a message when a run fails or a CSV lacks the columns it needs.
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

KEY = ["scene", "builder", "builder_params", "layout", "threads", "ray_set"]


def ratios(csv_path):
    """{cell key: ours over Embree} for one run's CSV."""
    import pandas as pd

    df = pd.read_csv(csv_path, dtype={"ray_set": str, "builder_params": str})
    missing = [c for c in KEY + ["trace_mrays_median", "build_ms_median"] if c not in df.columns]
    if missing:
        raise ValueError(f"{csv_path}: no column {', '.join(missing)}")
    df["ray_set"] = df["ray_set"].fillna("")
    df["builder_params"] = df["builder_params"].fillna("")
    embree = df[(df.builder == "embree") & (df.builder_params == "quality=medium")]
    trace_anchor = embree[embree.layout == "embree_1"].set_index(["scene", "threads", "ray_set"]).trace_mrays_median
    build_anchor = embree[embree.ray_set == ""].groupby(["scene", "threads"]).build_ms_median.first()
    out = {}
    for row in df[df.builder != "embree"].itertuples(index=False):
        key = tuple(getattr(row, k) for k in KEY)
        if row.ray_set:
            anchor = trace_anchor.get((row.scene, row.threads, row.ray_set))
            if anchor is not None and anchor > 0 and row.trace_mrays_median > 0:
                out[key] = row.trace_mrays_median / anchor
        else:
            anchor = build_anchor.get((row.scene, row.threads))
            if anchor is not None and row.build_ms_median > 0:
                out[key] = anchor / row.build_ms_median
    return out


def run_round(config, builds, order, folder, round_index, only):
    results = {}
    for b in order:
        csv_path = Path(folder) / f"round{round_index}_build{b}.csv"
        command = [builds[b], "run", config, "--output", str(csv_path)]
        if only:
            command += ["--only", only]
        print(f"round {round_index + 1}: {' '.join(command)}", file=sys.stderr)
        done = subprocess.run(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        if done.returncode != 0:
            tail = done.stderr.strip().splitlines()[-5:]
            raise RuntimeError(f"{builds[b]} run {config} exited {done.returncode}:\n" + "\n".join(tail))
        results[b] = ratios(csv_path)
    return results


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config", help="experiment config (TOML)")
    parser.add_argument("builds", nargs="+", help="sahbench executables, the first is the baseline")
    parser.add_argument("--rounds", type=int, default=4, help="rounds of one run per build (default 4)")
    parser.add_argument("--only", help="passed to sahbench run --only")
    args = parser.parse_args(argv)
    if len(args.builds) < 2:
        parser.error("give at least two builds to compare")
    if args.rounds < 1:
        parser.error(f"--rounds {args.rounds}: must be at least 1")
    for build in args.builds:
        if not (os.path.isfile(build) and os.access(build, os.X_OK)):
            parser.error(f"build '{build}' is not an executable file")
    if not os.path.isfile(args.config):
        parser.error(f"config '{args.config}' does not exist")

    per_build = [dict() for _ in args.builds]  # cell -> list of ratios over rounds
    with tempfile.TemporaryDirectory(prefix="sahbench-ab-") as folder:
        for r in range(args.rounds):
            order = list(range(len(args.builds)))
            if r % 2 == 1:
                order.reverse()
            try:
                results = run_round(args.config, args.builds, order, folder, r, args.only)
            except (RuntimeError, ValueError) as error:
                print(f"ab.py: {error}", file=sys.stderr)
                return 1
            for b, cells in results.items():
                for key, value in cells.items():
                    per_build[b].setdefault(key, []).append(value)

    cells = sorted(set().union(*[set(p) for p in per_build]), key=lambda k: tuple(str(x) for x in k))
    if not cells:
        print("ab.py: no cell with an Embree medium anchor in the runs", file=sys.stderr)
        return 1
    names = [chr(ord("A") + i) for i in range(len(args.builds))]
    print(f"# A/B, {args.rounds} interleaved rounds of {args.config}: median over rounds of ours over Embree medium")
    print("# (trace: rays/s ratio; build: Embree's time over ours; above 1 is faster than Embree)")
    for name, build in zip(names, args.builds):
        print(f"# {name}: {build}")
    header = ["scene", "builder", "params", "layout", "threads", "ray set"] + names
    header += [f"{n} vs {names[0]}" for n in names[1:]]
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for key in cells:
        medians = [statistics.median(p[key]) if key in p else None for p in per_build]
        row = [str(key[0]), str(key[1]), str(key[2]) or "-", str(key[3]), str(key[4]), str(key[5]) or "build"]
        row += [f"{m:.3f}" if m is not None else "-" for m in medians]
        for m in medians[1:]:
            row.append(f"{m / medians[0] - 1:+.1%}" if m is not None and medians[0] else "-")
        print("| " + " | ".join(row) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
