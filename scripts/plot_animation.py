#!/usr/bin/env python3
"""Plots an animation experiment (configs/animation.toml): per scene and thread count, the refit and
rebuild times of each of our builders and Embree's refit time over the frames, and the refitted tree's
SAH cost relative to a fresh build's: the time saved against the quality lost.

    python3 scripts/plot_animation.py results/animation.csv --out results/animation.png [--run RUN_ID]
"""
import argparse
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("csv")
    parser.add_argument("--out", required=True, help="image file (PNG, PDF, SVG by extension)")
    parser.add_argument("--run", help="run_id to plot (default: the latest in the file)")
    args = parser.parse_args()

    rows = pd.read_csv(args.csv)
    if "frame_time" not in rows.columns:
        sys.exit(f"{args.csv}: no frame_time column: not an animation experiment")
    run = args.run or rows["run_id"].iloc[-1]
    rows = rows[rows["run_id"] == run]
    if rows.empty:
        sys.exit(f"{args.csv}: no rows of run {run}")
    # Build time and SAH cost are per tree: the same in every layout and ray-set row of it.
    trees = rows.drop_duplicates(["scene", "threads", "frame", "builder", "builder_params"])
    groups = list(trees.groupby(["scene", "threads"], sort=False))
    fig, axes = plt.subplots(len(groups), 2, figsize=(11, 3.2 * len(groups)), squeeze=False)
    for (scene, threads), (ax_time, ax_sah) in zip([g for g, _ in groups], axes):
        group = trees[(trees["scene"] == scene) & (trees["threads"] == threads)]
        for (builder, params), series in group.groupby(["builder", "builder_params"], sort=False):
            series = series.sort_values("frame")
            label = builder if builder != "embree" else f"embree [{params}]"
            ax_time.plot(series["frame_time"], series["build_ms_median"], marker="o", label=label)
            if builder.startswith("refit("):
                rebuilt = group[(group["builder"] == builder[len("refit("):-1]) & (group["builder_params"] == params)]
                merged = series.merge(rebuilt, on="frame", suffixes=("", "_rebuild"))
                ax_sah.plot(merged["frame_time"], merged["sah_cost"] / merged["sah_cost_rebuild"], marker="o",
                            label=f"{builder} / rebuild")
        ax_time.set_yscale("log")
        ax_time.set_title(f"{scene}, {threads} thread(s): build or refit time")
        ax_time.set_xlabel("animation time (s)")
        ax_time.set_ylabel("ms (median)")
        ax_time.legend(fontsize="small")
        ax_sah.axhline(1.0, color="grey", linewidth=0.8)
        ax_sah.set_title("SAH cost of the refitted tree relative to a rebuild")
        ax_sah.set_xlabel("animation time (s)")
        ax_sah.legend(fontsize="small")
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
