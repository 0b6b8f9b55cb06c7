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

Timings on a shared machine vary by 10-25% between runs; the ratio of our figure to Embree's in the same
run cancels part of that (how much, an A/A run of the config shows: README). So for each cell (scene,
builder and parameters, layout, threads, ray set) the script prints, per build, the median over rounds
of:
- trace cells: our rays/second over Embree medium's `embree_1` (rtcIntersect1 / rtcOccluded1) on the
  same rays in the same run: above 1 is faster than Embree;
- build cells (one per scene, builder and parameters, threads; printed with ray set "build"): Embree
  medium's build time (`embree_1`, default mode) over ours, from any of the cell's rows (they carry the
  same build), the same way round: above 1 is faster.
and, for each build after the first, its change against the first build, with a 95% interval: the
ratio of the two builds' figures is taken round by round (both ran back to back in that round), and the
change is the geometric mean of those per-round ratios with Student's t interval on their logarithms
(as harness/report/ratio_stats.h does for ratios to Embree). `▲` or `▼` marks a change whose interval
excludes zero; with one round there is no interval. Within a run, the ratio to Embree is the geometric
mean of the ratios of samples taken in the same round (`trace_mrays_samples`, `build_ms_samples`) where
the CSV has them, else the ratio of medians; samples of different counts, or negative ones, are an
error naming the cell, as in `sahbench report`, and a sample of 0 (a time printed as 0.0000 ms) leaves
the cell without a ratio. An animated config's frames are
cells of their own. Use an even number of rounds, so that each build runs first equally often.

Needs pandas. Exits 1 with a message when a run fails, a CSV lacks the columns it needs or the anchor's
rows (a config without Embree medium in its default mode: after the first run), or the first round
gives no cell a ratio (after that round).
"""

import argparse
import math
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

KEY = ["scene", "builder", "builder_params", "layout", "threads", "ray_set"]


# t(0.975, df) for df 1..30 (Student's t, two-sided 95%); beyond 30 the value at 30, the wider side.
T_975 = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160, 2.145,
         2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048,
         2.045, 2.042]


def samples(text):
    """The numbers of a `*_samples` cell ("12.5;12.7"), [] where it is empty; ValueError where one is
    not a number, negative or not finite."""
    if not isinstance(text, str) or not text:
        return []
    try:
        values = [float(x) for x in text.split(";")]
    except ValueError:
        raise ValueError(f"samples '{text}' are not numbers") from None
    if not all(v >= 0 and math.isfinite(v) for v in values):
        raise ValueError(f"samples '{text}' are not all finite and at least 0")
    return values


def paired(num_samples, den_samples, num_median, den_median):
    """num / den: the geometric mean of the ratios of samples taken in the same round, where both have
    samples, else the ratio of medians; None where neither gives a positive figure, or a sample is 0 (a
    time printed as 0.0000 ms has no ratio). ValueError where both have samples of different counts: they
    are not paired by round."""
    if num_samples and den_samples:
        if len(num_samples) != len(den_samples):
            raise ValueError(f"{len(num_samples)} samples against the anchor's {len(den_samples)}")
        if min(num_samples) <= 0 or min(den_samples) <= 0:
            return None
        return math.exp(sum(math.log(a / b) for a, b in zip(num_samples, den_samples)) / len(num_samples))
    if num_median > 0 and den_median > 0:
        return num_median / den_median
    return None


def ratios(csv_path):
    """{cell key: ours over Embree} for one run's CSV."""
    import pandas as pd

    df = pd.read_csv(csv_path, dtype={"ray_set": str, "builder_params": str})
    missing = [c for c in KEY + ["trace_mrays_median", "build_ms_median"] if c not in df.columns]
    if missing:
        raise ValueError(f"{csv_path}: no column {', '.join(missing)}")
    df["ray_set"] = df["ray_set"].fillna("")
    df["builder_params"] = df["builder_params"].fillna("")
    df["layout"] = df["layout"].fillna("")
    for column in ("trace_mrays_samples", "build_ms_samples"):
        if column not in df.columns:
            df[column] = ""
        df[column] = df[column].fillna("").astype(str)
    # Animated configs write a row per frame; each frame is its own cell against Embree's same frame.
    df["frame"] = df["frame"].fillna(0).astype(int) if "frame" in df.columns else 0
    embree = df[(df.builder == "embree") & (df.builder_params == "quality=medium") & (df.layout == "embree_1")]
    if embree.empty:
        raise ValueError(f"{csv_path}: no row of the anchor, Embree medium's embree_1 in its default mode "
                         "(robust = false): add it to the config")
    trace_anchor = embree.drop_duplicates(["scene", "frame", "threads", "ray_set"])
    trace_anchor = trace_anchor.set_index(["scene", "frame", "threads", "ray_set"]).sort_index()
    # Every row of a build carries its build time: one row per build, ours and Embree's.
    build_anchor = embree.drop_duplicates(["scene", "frame", "threads"]).set_index(["scene", "frame", "threads"])
    ours_rows = df[df.builder != "embree"]
    builds = ours_rows.drop_duplicates(["scene", "frame", "threads", "builder", "builder_params"])

    def cell(row, anchors_of, at, key, samples_column, median_column, ours_over_embree):
        if at not in anchors_of.index:
            return
        if row.frame:
            key = (f"{row.scene} (frame {row.frame})",) + key[1:]
        anchor = anchors_of.loc[at]
        try:
            ours = (samples(getattr(row, samples_column)), getattr(row, median_column))
            embree_figures = (samples(getattr(anchor, samples_column)), getattr(anchor, median_column))
            num, den = (ours, embree_figures) if ours_over_embree else (embree_figures, ours)
            value = paired(num[0], den[0], num[1], den[1])
        except ValueError as error:
            raise ValueError(f"{csv_path}: {' '.join(str(k) for k in key if k != '')}: {error}") from None
        if value is not None:
            out[key] = value

    # Trace: our rays/s over Embree's; build: Embree's time over ours. Either way above 1 is faster.
    out = {}
    for row in ours_rows.itertuples(index=False):
        cell(row, trace_anchor, (row.scene, row.frame, row.threads, row.ray_set), tuple(getattr(row, k) for k in KEY),
             "trace_mrays_samples", "trace_mrays_median", True)
    for row in builds.itertuples(index=False):
        cell(row, build_anchor, (row.scene, row.frame, row.threads),
             (row.scene, row.builder, row.builder_params, "", row.threads, ""), "build_ms_samples",
             "build_ms_median", False)
    return out


def change(base, new):
    """How `new` changed against `base`, both lists of one figure per round (None where a round lacks
    it): (estimate, low, high) as fractions (+0.125 is 12.5% higher), low and high None with fewer than
    two rounds that have both."""
    logs = [math.log(b / a) for a, b in zip(base, new) if a is not None and b is not None]
    if not logs:
        return None
    mean = sum(logs) / len(logs)
    if len(logs) < 2:
        return math.exp(mean) - 1, None, None
    half = T_975[min(len(logs) - 1, len(T_975)) - 1] * statistics.stdev(logs) / math.sqrt(len(logs))
    return math.exp(mean) - 1, math.exp(mean - half) - 1, math.exp(mean + half) - 1


def format_change(c):
    """change()'s result as "+12.5% [+10.1%, +14.9%] ▲"."""
    if c is None:
        return "-"
    estimate, low, high = c
    if low is None:
        return f"{estimate:+.1%} (1 round)"
    mark = " ▲" if low > 0 else " ▼" if high < 0 else ""
    return f"{estimate:+.1%} [{low:+.1%}, {high:+.1%}]{mark}"


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

    per_build = [dict() for _ in args.builds]  # cell -> {round: ratio}
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
                    per_build[b].setdefault(key, {})[r] = value
            # Every round would be as empty as the first: say so now, not after the last.
            if not any(per_build):
                print("ab.py: no cell of round 1 has a ratio: none of ours shares a scene, threads and ray set "
                      "with the anchor, or every sample is 0", file=sys.stderr)
                return 1

    cells = sorted(set().union(*[set(p) for p in per_build]), key=lambda k: tuple(str(x) for x in k))
    names = [chr(ord("A") + i) for i in range(len(args.builds))]
    print(f"# A/B, {args.rounds} interleaved rounds of {args.config}: median over rounds of ours over Embree medium")
    print("# (trace: rays/s ratio; build: Embree's time over ours; above 1 is faster than Embree);")
    print("# changes: geometric mean over rounds of the builds' ratio in that round, [95% interval]")
    for name, build in zip(names, args.builds):
        print(f"# {name}: {build}")
    header = ["scene", "builder", "params", "layout", "threads", "ray set"] + names
    header += [f"{n} vs {names[0]}" for n in names[1:]]
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    changes = [[] for _ in per_build[1:]]  # per later build: (is a build cell, change)
    for key in cells:
        medians = [statistics.median(p[key].values()) if key in p else None for p in per_build]
        row = [str(key[0]), str(key[1]), str(key[2]) or "-", str(key[3]) or "-", str(key[4]), str(key[5]) or "build"]
        row += [f"{m:.3f}" if m is not None else "-" for m in medians]
        base = [per_build[0].get(key, {}).get(r) for r in range(args.rounds)]
        for i, p in enumerate(per_build[1:]):
            c = change(base, [p.get(key, {}).get(r) for r in range(args.rounds)])
            row.append(format_change(c))
            if c is not None:
                changes[i].append((not key[5], c))
        print("| " + " | ".join(row) + " |")
    print()
    for name, build_changes in zip(names[1:], changes):
        for is_build, kind in ((False, "trace"), (True, "build")):
            print(summary_line(f"{name} vs {names[0]}, {kind} cells",
                               [c for b, c in build_changes if b == is_build]))
    return 0


def summary_line(title, cell_changes):
    """One build's verdicts over its cells: how many are faster (▲), slower (▼) or within noise by their
    intervals, and the median change, so that a change is read over the whole config, not one cell."""
    if not cell_changes:
        return f"# {title}: none"
    faster = sum(1 for _, low, _ in cell_changes if low is not None and low > 0)
    slower = sum(1 for _, _, high in cell_changes if high is not None and high < 0)
    bare = sum(1 for _, low, _ in cell_changes if low is None)
    noise = len(cell_changes) - faster - slower - bare
    text = f"# {title}: {len(cell_changes)}, ▲ {faster}, ▼ {slower}, within noise {noise}"
    if bare:
        text += f", {bare} of one round"
    median = statistics.median(estimate for estimate, _, _ in cell_changes)
    return text + f"; median change {median:+.1%}"


if __name__ == "__main__":
    sys.exit(main())
