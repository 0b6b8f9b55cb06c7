#!/usr/bin/python3
"""Plots from sahbench result CSVs (sahbench run / stress / animation experiments).

    scripts/plots.py results/default.csv [more.csv ...] [--out DIR] [--all-runs]

Writes PNG and PDF files named <stem>_<kind>[_<scene>].{png,pdf} (stem: the first CSV's name) into
DIR, by default the first CSV's folder, for each kind whose columns are in the data:

  build_vs_trace   per scene and thread count, one panel per ray set: build time against the time to
                   trace the set, one point per builder run and layout; Embree as stars.
  errors_vs_speed  stress suite rows (false_misses, false_hits, wrong_prim, leaks): total errors summed
                   over the cases (symlog axis) against the median rays/s, one point per variant.
  sah_vs_bins      builder runs with bins=N in builder_params: SAH cost against the bin count, one
                   panel per scene, with the full-sweep builder's cost as a line where it was run.
  refit_vs_rebuild animation experiments (frame column with frames > 0, builders "refit(NAME)" beside
                   "NAME", or Embree quality=refit beside quality=medium): per frame, the refitted
                   tree's SAH cost and trace time relative to a fresh build (quality lost) and the refit
                   time relative to the build time (time saved).

A kind whose columns are absent is skipped with a message; the script fails only on unreadable input.
By default only the latest run of each file is plotted (rows are appended as cells finish, so the last
row's run_id), as `sahbench report` does.
"""

import argparse
import math
import re
import sys
from pathlib import Path

try:
    import matplotlib

    matplotlib.use("Agg")  # files only, no display
    import matplotlib.pyplot as plt
    import matplotlib.ticker as ticker
    import pandas as pd
except ImportError as e:  # the script is useless without them; say which one is missing
    sys.exit(f"plots.py: {e.name} is missing (Debian: apt-get install python3-matplotlib python3-pandas)")

NUMERIC = [
    "threads", "scene_triangles", "frame", "build_ms_median", "build_ms_min", "build_ms_max", "mem_bytes",
    "sah_cost", "ray_count", "trace_mrays_median", "trace_mrays_min", "trace_mrays_max",
    "false_misses", "false_hits", "wrong_prim", "leaks", "t_err_ulps_max", "t_err_ulps_mean", "layout_ms",
    "layout_refit_ms",
]
ERROR_COLUMNS = ["false_misses", "false_hits", "wrong_prim", "leaks"]
TEXT = ["run_id", "scene", "builder", "builder_params", "layout", "ray_set", "cpu", "git_commit"]


def log(message):
    print(f"plots.py: {message}", file=sys.stderr)


def load(paths, all_runs):
    frames = []
    for path in paths:
        try:
            df = pd.read_csv(path, dtype=str, keep_default_na=False)
        except (OSError, pd.errors.ParserError, pd.errors.EmptyDataError) as e:
            sys.exit(f"plots.py: {path}: cannot read: {e}")
        if not all_runs and "run_id" in df.columns and len(df):
            df = df[df["run_id"] == df["run_id"].iloc[-1]]
        frames.append(df)
    data = pd.concat(frames, ignore_index=True, sort=False)
    for column in NUMERIC:
        if column in data.columns:
            data[column] = pd.to_numeric(data[column], errors="coerce")
    for column in TEXT:
        if column in data.columns:
            data[column] = data[column].fillna("").astype(str)
    if "builder_params" not in data.columns:  # optional everywhere: a builder without parameters
        data["builder_params"] = ""
    return data


def has(data, columns):
    return all(c in data.columns for c in columns) and len(data) > 0


def slug(text):
    return re.sub(r"[^A-Za-z0-9.-]+", "_", str(text)).strip("_") or "scene"


def plain_log_ticks(axis, locator=True):
    """Log-scaled axis labelled 1, 2, 5, 10, 20 rather than 10^0, 2x10^1; enough labels for a range of
    less than a decade. locator=False keeps ticks set elsewhere (bin counts)."""
    if locator:
        axis.set_major_locator(ticker.LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(ticker.FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_formatter(ticker.NullFormatter())


def split_params(params):
    return [tuple(item.split("=", 1)) if "=" in item else (item, "") for item in str(params).split(";") if item]


def builder_labels(data):
    """A short label per (builder, builder_params): only the parameters that vary between the runs of
    that builder, as in the LaTeX report."""
    labels = {}
    runs = sorted(set(zip(data["builder"], data["builder_params"])))
    for builder in {b for b, _ in runs}:
        values = {}
        for b, p in runs:
            if b == builder:
                for k, v in split_params(p):
                    values.setdefault(k, set()).add(v)
        for b, p in runs:
            if b == builder:
                varying = [f"{k}={v}" for k, v in split_params(p) if len(values.get(k, ())) > 1]
                labels[(b, p)] = builder + (f" [{';'.join(varying)}]" if varying else "")
    return labels


def is_embree(builder):
    return str(builder).startswith("embree")


def save(fig, out_dir, stem, kind, suffix=""):
    name = f"{stem}_{kind}" + (f"_{slug(suffix)}" if suffix else "")
    written = []
    for ext in ("png", "pdf"):
        path = out_dir / f"{name}.{ext}"
        fig.savefig(path, dpi=150, bbox_inches="tight")
        written.append(path)
    plt.close(fig)
    for path in written:
        print(path)
    return written


def caption(rows):
    """Machine and commit of the rows, for figure titles."""
    parts = []
    for column in ("cpu", "git_commit"):
        if column in rows.columns:
            values = sorted({v for v in rows[column] if v})
            if values:
                parts.append(("commit " if column == "git_commit" else "") + ", ".join(values[:2]))
    return "; ".join(parts)


def plot_build_vs_trace(data, out_dir, stem):
    need = ["scene", "builder", "layout", "ray_set", "build_ms_median", "trace_mrays_median", "ray_count"]
    if not has(data, need):
        return log("build_vs_trace: skipped, missing columns " + ", ".join(c for c in need if c not in data.columns))
    rows = data.dropna(subset=["build_ms_median", "trace_mrays_median", "ray_count"])
    rows = rows[(rows["trace_mrays_median"] > 0) & (rows["build_ms_median"] > 0)]
    if "frame" in rows.columns:  # animation frames have plots of their own
        rows = rows[rows["frame"].fillna(0) == 0]
    if rows.empty:
        return log("build_vs_trace: skipped, no rows with build and trace times")
    labels = builder_labels(rows)
    threads = rows["threads"] if "threads" in rows.columns else pd.Series([1] * len(rows), index=rows.index)
    rows = rows.assign(_threads=threads.fillna(1).astype(int),
                       _trace_ms=rows["ray_count"] / (rows["trace_mrays_median"] * 1e6) * 1e3)
    written = []
    for (scene, nthreads), group in rows.groupby(["scene", "_threads"], sort=False):
        ray_sets = list(dict.fromkeys(group["ray_set"]))
        cols = min(len(ray_sets), 2)
        nrows = math.ceil(len(ray_sets) / cols)
        fig, axes = plt.subplots(nrows, cols, figsize=(6.0 * cols, 4.2 * nrows), squeeze=False)
        series = list(dict.fromkeys(zip(group["builder"], group["builder_params"], group["layout"])))
        cmap = plt.get_cmap("tab20")
        for i, ray_set in enumerate(ray_sets):
            ax = axes[i // cols][i % cols]
            subset = group[group["ray_set"] == ray_set]
            for j, (builder, params, layout) in enumerate(series):
                point = subset[(subset["builder"] == builder) & (subset["builder_params"] == params)
                               & (subset["layout"] == layout)]
                if point.empty:
                    continue
                embree = is_embree(builder)
                ax.scatter(point["build_ms_median"], point["_trace_ms"], s=110 if embree else 40,
                           marker="*" if embree else "o", color=cmap(j % 20), edgecolors="black",
                           linewidths=0.5, label=f"{labels[(builder, params)]} / {layout}", zorder=3)
            ax.set_xscale("log")
            ax.set_yscale("log")
            plain_log_ticks(ax.xaxis)
            plain_log_ticks(ax.yaxis)
            ax.set_xlabel("build time (ms, median)")
            ax.set_ylabel(f"trace time of the {ray_set} set (ms)")
            ax.set_title(f"{ray_set} ({int(subset['ray_count'].iloc[0])} rays)")
            ax.grid(True, which="both", alpha=0.3)
        for k in range(len(ray_sets), nrows * cols):
            axes[k // cols][k % cols].axis("off")
        handles, names = axes[0][0].get_legend_handles_labels()
        fig.legend(handles, names, loc="upper center", bbox_to_anchor=(0.5, 0.0), ncol=2, fontsize=8, frameon=False)
        fig.suptitle(f"{scene}, {nthreads} thread{'s' if nthreads != 1 else ''}: build vs trace time "
                     f"(lower left is better; stars: Embree)\n{caption(group)}", fontsize=10)
        fig.tight_layout()
        written += save(fig, out_dir, stem, "build_vs_trace", f"{scene}_t{nthreads}")
    return written


def plot_errors_vs_speed(data, out_dir, stem):
    present = [c for c in ERROR_COLUMNS if c in data.columns]
    need = ["builder", "layout", "trace_mrays_median"]
    if not present or not has(data, need):
        return log("errors_vs_speed: skipped, no stress-suite columns (" + ", ".join(ERROR_COLUMNS) + ")")
    rows = data.dropna(subset=present, how="all").dropna(subset=["trace_mrays_median"])
    if rows.empty:
        return log("errors_vs_speed: skipped, no rows with error counts and rays/s")
    labels = builder_labels(rows)
    rows = rows.assign(_errors=rows[present].fillna(0).sum(axis=1))
    variants = rows.groupby(["builder", "builder_params", "layout"], sort=False).agg(
        errors=("_errors", "sum"), mrays=("trace_mrays_median", "median"), cases=("_errors", "size")).reset_index()
    fig, ax = plt.subplots(figsize=(7.5, 5.0))
    cmap = plt.get_cmap("tab20")
    for j, v in variants.iterrows():
        embree = is_embree(v["builder"])
        label = f"{labels[(v['builder'], v['builder_params'])]} / {v['layout']}"
        ax.scatter(v["mrays"], v["errors"], s=110 if embree else 45, marker="*" if embree else "o",
                   color=cmap(j % 20), edgecolors="black", linewidths=0.5, label=label, zorder=3)
    ax.set_yscale("symlog", linthresh=1)
    ax.set_ylim(bottom=-0.5)
    ax.set_xlabel("rays/s (Mrays/s, median over the cases)")
    ax.set_ylabel("errors, summed over the cases")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), frameon=False)
    ax.set_title(f"Errors vs speed over {int(variants['cases'].max())} stress cases "
                 f"(lower right is better; stars: Embree)\nerrors = {' + '.join(present)}; {caption(rows)}",
                 fontsize=9)
    fig.tight_layout()
    return save(fig, out_dir, stem, "errors_vs_speed")


def bins_of(params):
    match = re.search(r"(?:^|;)bins=(\d+)", str(params))
    return int(match.group(1)) if match else None


def plot_sah_vs_bins(data, out_dir, stem):
    need = ["scene", "builder", "builder_params", "sah_cost"]
    if not has(data, need):
        return log("sah_vs_bins: skipped, missing columns " + ", ".join(c for c in need if c not in data.columns))
    rows = data.dropna(subset=["sah_cost"])
    if "frame" in rows.columns:
        rows = rows[rows["frame"].fillna(0) == 0]
    # Refitted trees keep the bins of their first build but are not what the bin count produced.
    rows = rows.loc[pd.Series([refit_base(b, p) is None for b, p in zip(rows["builder"], rows["builder_params"])],
                              index=rows.index, dtype=bool)]
    rows = rows.assign(_bins=rows["builder_params"].map(bins_of))
    binned = rows.dropna(subset=["_bins"])
    if binned["_bins"].nunique() < 2:
        return log("sah_vs_bins: skipped, fewer than two bin counts (bins=N in builder_params)")
    # SAH cost depends on the tree only, not on layout, ray set or threads: one value per run.
    binned = binned.assign(_rest=binned["builder_params"].map(
        lambda p: ";".join(f"{k}={v}" for k, v in split_params(p) if k != "bins")))
    scenes = list(dict.fromkeys(binned["scene"]))
    cols = min(len(scenes), 3)
    nrows = math.ceil(len(scenes) / cols)
    fig, axes = plt.subplots(nrows, cols, figsize=(4.8 * cols, 3.8 * nrows), squeeze=False)
    for i, scene in enumerate(scenes):
        ax = axes[i // cols][i % cols]
        subset = binned[binned["scene"] == scene]
        rests = list(dict.fromkeys(zip(subset["builder"], subset["_rest"])))
        varying = {k for r in rests for k, v in split_params(r[1])
                   if len({dict(split_params(x[1])).get(k) for x in rests if x[0] == r[0]}) > 1}
        for builder, rest in rests:
            line = subset[(subset["builder"] == builder) & (subset["_rest"] == rest)]
            line = line.groupby("_bins")["sah_cost"].first().sort_index()
            extra = ";".join(f"{k}={v}" for k, v in split_params(rest) if k in varying)
            ax.plot(line.index, line.values, marker="o", label=builder + (f" [{extra}]" if extra else ""))
        sweep = rows[(rows["scene"] == scene) & (rows["builder"] == "sweep_sah")]["sah_cost"]
        if not sweep.empty:
            ax.axhline(sweep.iloc[0], color="gray", linestyle="--", label="sweep_sah (every split)")
        ax.set_xscale("log", base=2)
        ax.set_xticks(sorted(subset["_bins"].unique()))
        plain_log_ticks(ax.xaxis, locator=False)
        ax.set_xlabel("bins")
        ax.set_ylabel("SAH cost")
        ax.set_title(str(scene), fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    for k in range(len(scenes), nrows * cols):
        axes[k // cols][k % cols].axis("off")
    fig.suptitle(f"SAH cost vs bin count (lower is better)\n{caption(binned)}", fontsize=10)
    fig.tight_layout()
    return save(fig, out_dir, stem, "sah_vs_bins")


def refit_base(builder, params):
    """The (builder, params) of the fresh build a refit row is compared with, or None for a build."""
    match = re.fullmatch(r"refit\((.+)\)", str(builder))
    if match:
        return match.group(1), params
    if builder == "embree" and "quality=refit" in str(params):
        return "embree", str(params).replace("quality=refit", "quality=medium")
    if builder == "embree_refit":
        return "embree", "quality=medium"
    return None


def short_series(builder, params):
    """A legend label: the builder with only its arity, quality or Embree's robust mode (the full parameters
    are in the CSV)."""
    keep = [kv for kv in str(params if isinstance(params, str) else "").split(";")
            if kv.split("=")[0] in ("arity", "quality", "robust")]
    return f"{builder} {','.join(keep)}".strip()


def plot_refit_vs_rebuild(data, out_dir, stem):
    need = ["scene", "frame", "builder", "build_ms_median"]
    if not has(data, need) or not (data["frame"].fillna(0) > 0).any():
        return log("refit_vs_rebuild: skipped, no animation frames (frame > 0)")
    rows = data.copy()
    rows["_base"] = [refit_base(b, p) for b, p in zip(rows["builder"], rows["builder_params"])]
    refits = rows[rows["_base"].notna()]
    if refits.empty:
        return log("refit_vs_rebuild: skipped, no refit rows (builder refit(NAME) or Embree quality=refit)")
    key = [c for c in ("scene", "threads", "frame", "layout", "ray_set") if c in rows.columns]
    builds = rows[rows["_base"].isna()].set_index(key + ["builder", "builder_params"])
    pairs = []
    for _, r in refits.iterrows():
        index = tuple(r[c] for c in key) + r["_base"]
        if index not in builds.index:
            continue
        b = builds.loc[index]
        b = b.iloc[0] if isinstance(b, pd.DataFrame) else b
        pairs.append({
            "scene": r["scene"], "threads": r.get("threads", 1), "frame": r["frame"],
            "series": short_series(r["builder"], r["builder_params"]),
            "layout": r.get("layout", ""), "ray_set": r.get("ray_set", ""),
            "sah": r.get("sah_cost", float("nan")) / b.get("sah_cost", float("nan")) if "sah_cost" in rows.columns
            else float("nan"),
            "time": r["build_ms_median"] / b["build_ms_median"],
            # With the layout: tree refit + layout refit against build + layout compile.
            "time_total": (r["build_ms_median"] + r.get("layout_refit_ms", float("nan")))
            / (b["build_ms_median"] + b.get("layout_ms", float("nan"))) if "layout_refit_ms" in rows.columns
            else float("nan"),
            "trace": b.get("trace_mrays_median", float("nan")) / r.get("trace_mrays_median", float("nan"))
            if "trace_mrays_median" in rows.columns else float("nan"),
        })
    if not pairs:
        return log("refit_vs_rebuild: skipped, no refit row has a fresh build of the same frame beside it")
    pairs = pd.DataFrame(pairs)
    written = []
    for (scene, nthreads), group in pairs.groupby(["scene", "threads"], sort=False):
        fig, (ax_q, ax_t) = plt.subplots(2, 1, figsize=(11.0, 6.5), sharex=True)
        for series, s in group.groupby("series", sort=False):
            # SAH and build time do not depend on the layout or ray set: one line per series.
            per_frame = s.groupby("frame").first().sort_index()
            color = ax_t.plot(per_frame.index, per_frame["time"], marker="o", label=series)[0].get_color()
            for layout, per_layout in s.dropna(subset=["time_total"]).groupby("layout", sort=False):
                totals = per_layout.groupby("frame")["time_total"].first().sort_index()
                ax_t.plot(totals.index, totals.values, linestyle=":", marker=".", color=color,
                          label=f"{series}: with the {layout} layout's refit / compile")
            if per_frame["sah"].notna().any():  # Embree's own trees have no SAH cost of ours
                ax_q.plot(per_frame.index, per_frame["sah"], marker="o", color=color, label=f"{series}: SAH cost")
            traced = s.dropna(subset=["trace"])
            if not traced.empty:
                first = traced[(traced["layout"] == traced["layout"].iloc[0]) & (traced["ray_set"] == traced["ray_set"].iloc[0])]
                first = first.groupby("frame")["trace"].first().sort_index()
                ax_q.plot(first.index, first.values, linestyle="--", color=color,
                          label=f"{series}: trace time ({traced['layout'].iloc[0]}, {traced['ray_set'].iloc[0]})")
        ax_q.axhline(1.0, color="gray", linewidth=0.8)
        ax_t.axhline(1.0, color="gray", linewidth=0.8)
        ax_q.set_ylabel("refit / rebuild\n(quality lost: > 1 is worse)")
        ax_t.set_ylabel("refit time / build time\n(time saved: < 1)")
        ax_t.set_xlabel("frame")
        ax_t.set_yscale("log")
        plain_log_ticks(ax_t.yaxis)
        ax_t.xaxis.set_major_locator(ticker.MaxNLocator(integer=True))
        for ax in (ax_q, ax_t):
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
        fig.suptitle(f"{scene}, {nthreads} thread{'s' if nthreads != 1 else ''}: refit vs rebuild per frame\n"
                     f"{caption(data[data['scene'] == scene])}", fontsize=10)
        fig.tight_layout()
        written += save(fig, out_dir, stem, "refit_vs_rebuild", f"{scene}_t{nthreads}")
    return written


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("csv", nargs="+", type=Path, help="result CSV files")
    parser.add_argument("--out", type=Path, help="output folder (default: the first CSV's folder)")
    parser.add_argument("--all-runs", action="store_true", help="plot every run in the files, not only the latest")
    args = parser.parse_args(argv)
    for path in args.csv:
        if not path.is_file():
            sys.exit(f"plots.py: {path}: no such file")
    out_dir = args.out or args.csv[0].resolve().parent
    out_dir.mkdir(parents=True, exist_ok=True)
    data = load(args.csv, args.all_runs)
    if data.empty:
        sys.exit(f"plots.py: no rows in {', '.join(map(str, args.csv))}")
    stem = args.csv[0].stem
    written, failed = [], []
    for plot in (plot_build_vs_trace, plot_errors_vs_speed, plot_sah_vs_bins, plot_refit_vs_rebuild):
        # One kind failing on unexpected data must not cost the others; the exit code still says so.
        try:
            written += plot(data, out_dir, stem) or []
        except Exception as e:  # noqa: BLE001
            kind = plot.__name__.removeprefix("plot_")
            log(f"{kind}: failed: {type(e).__name__}: {e}")
            failed.append(kind)
            plt.close("all")
    log(f"{len(written)} files in {out_dir}" + (f"; failed: {', '.join(failed)}" if failed else ""))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
