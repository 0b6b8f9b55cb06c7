#!/usr/bin/python3
"""Plots from sahbench result CSVs (sahbench run / stress / animation experiments).

    scripts/plots.py results/default.csv [more.csv ...] [--out DIR] [--all-runs]

Writes PNG and PDF files named <stem>_<kind>[_<scene>].{png,pdf} (stem: the first CSV's name) into
DIR, by default the first CSV's folder, for each kind whose columns are in the data:

  pareto           per scene and thread count, one panel per ray set: build + layout time against
                   rays/s, every builder run and layout a point with error bars (the 95% interval of
                   the geometric mean over the rounds, Student's t on the logs of the *_samples; min to
                   max without samples), the Pareto front (no other point both faster to build and
                   faster to trace) as a line, every point labelled, the labels moved apart.
  build_vs_trace   per scene and thread count, one panel per ray set: build time against the time to
                   trace the set, one point per builder run and layout; Embree as stars.
  errors_vs_speed  stress suite rows (false_misses, false_hits, wrong_prim, leaks): total errors summed
                   over the cases (symlog axis) against the median rays/s, one point per variant.
  sah_vs_bins      builder runs with bins=N in builder_params: SAH cost against the bin count, one
                   panel per tree arity and SAH cost model (c_trav, c_isect, block: costs under two
                   models are not comparable), a line per scene and builder, with the full-sweep
                   builder's cost as a dashed line where it was run.
  refit_vs_rebuild animation experiments (frame column with frames > 0, builders "refit(NAME)" beside
                   "NAME", or Embree quality=refit beside quality=medium): per frame, the refitted
                   tree's SAH cost and trace time relative to a fresh build (quality lost) and the refit
                   time relative to the build time (time saved).

Every title names the scene, threads, CPU and commit. PDFs embed their fonts as TrueType (pdf.fonttype
42), which publishers' checks accept and Type 3 fonts fail. A kind whose columns are absent is skipped
with a message; the script fails only on unreadable input.
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
    # TrueType fonts embedded in PDF (and PostScript) rather than Type 3, as publishers require.
    matplotlib.rcParams["pdf.fonttype"] = 42
    matplotlib.rcParams["ps.fonttype"] = 42
    import matplotlib.pyplot as plt
    import matplotlib.text
    import matplotlib.ticker as ticker
    import pandas as pd
except ImportError as e:  # the script is useless without them; say which one is missing
    sys.exit(f"plots.py: {e.name} is missing (Debian: apt-get install python3-matplotlib python3-pandas)")

NUMERIC = [
    "threads", "scene_triangles", "frame", "build_ms_median", "build_ms_min", "build_ms_max", "mem_bytes",
    "sah_cost", "ray_count", "trace_mrays_median", "trace_mrays_min", "trace_mrays_max",
    "false_misses", "false_hits", "wrong_prim", "leaks", "t_err_ulps_max", "t_err_ulps_mean", "layout_ms",
    "layout_refit_ms", "build_layout_ms_median", "arity", "sah_c_trav", "sah_c_isect", "sah_block",
]
ERROR_COLUMNS = ["false_misses", "false_hits", "wrong_prim", "leaks"]
TEXT = ["run_id", "scene", "builder", "builder_params", "layout", "ray_set", "cpu", "git_commit",
        "build_layout_ms_samples", "trace_mrays_samples"]


def log(message):
    print(f"plots.py: {message}", file=sys.stderr)


# Measured quantities, checked where a row has them: rates and ray counts finite and positive, times
# (a tiny build prints 0.0000 ms), bytes and costs finite and not negative. A figure would otherwise
# drop the point, or draw it, without a word.
POSITIVE = ["trace_mrays_median", "trace_mrays_min", "trace_mrays_max", "ray_count"]
NOT_NEGATIVE = ["build_ms_median", "build_ms_min", "build_ms_max", "build_layout_ms_median", "mem_bytes",
                "sah_cost"]


def check_measured(path, df):
    """Exits 2 naming the file, line and column of a measured field out of its range."""
    finite = lambda v: v.abs() < float("inf")  # noqa: E731 (False for NaN too)
    for columns, ok, what in ((POSITIVE, lambda v: finite(v) & (v > 0), "a finite positive number"),
                              (NOT_NEGATIVE, lambda v: finite(v) & (v >= 0), "a finite number of at least 0")):
        for column in columns:
            if column not in df.columns:
                continue
            text = df[column].astype(str).str.strip()
            bad = (text != "") & ~ok(pd.to_numeric(text, errors="coerce"))
            if bad.any():
                row = bad.to_numpy().nonzero()[0][0]
                # The file's line where it has no blank lines (pandas skips those): the header is line 1.
                print(f"plots.py: {path}:{df.index[row] + 2}: column '{column}': '{text.iloc[row]}' is not "
                      f"{what}", file=sys.stderr)
                sys.exit(2)


def load(paths, all_runs):
    frames = []
    for path in paths:
        try:
            df = pd.read_csv(path, dtype=str, keep_default_na=False)
        except (OSError, pd.errors.ParserError, pd.errors.EmptyDataError) as e:
            sys.exit(f"plots.py: {path}: cannot read: {e}")
        if not all_runs and "run_id" in df.columns and len(df):
            df = df[df["run_id"] == df["run_id"].iloc[-1]]
        check_measured(path, df)
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
        values, counts, hashes = {}, {}, {}
        own = [p for b, p in runs if b == builder]
        for p in own:
            fields = dict(split_params(p))
            for k, v in fields.items():
                values.setdefault(k, set()).add(v)
                counts[k] = counts.get(k, 0) + 1
                if k.endswith("_hash"):  # K_hash: the hashes seen with each value of K
                    hashes.setdefault(k, {}).setdefault(fields.get(k[:-5]), set()).add(v)

        def varies(k):
            # A key some runs lack (Embree's robust=1) varies too, as in the report's labels.
            return len(values.get(k, ())) > 1 or counts.get(k, 0) < len(own)

        def redundant_hash(k):
            # A file's hash beside its varying name (the tree file builder's path_hash), where each name
            # comes with one hash (two files of one name in two folders keep theirs), as in the report.
            named = k[:-5]
            return (k.endswith("_hash") and named in values and varies(named)
                    and all(len(h) == 1 for h in hashes[k].values()))

        for p in own:
            varying = [f"{k}={v}" for k, v in split_params(p) if varies(k) and not redundant_hash(k)]
            labels[(builder, p)] = builder + (f" [{';'.join(varying)}]" if varying else "")
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
    """Threads, machine and commit of the rows, for figure titles."""
    parts = []
    if "threads" in rows.columns:
        threads = sorted({int(t) for t in rows["threads"].dropna()})
        if threads:
            parts.append(f"{', '.join(map(str, threads))} thread{'s' if threads != [1] else ''}")
    for column in ("cpu", "git_commit"):
        if column in rows.columns:
            values = sorted({v for v in rows[column] if v})
            if values:
                parts.append(("commit " if column == "git_commit" else "") + ", ".join(values[:2]))
    return "; ".join(parts)


# Two-sided 95% quantiles of Student's t for 1..30 degrees of freedom (any statistics table); beyond, the
# Cornish-Fisher series (t_975 below), as harness/report/ratio_stats.cpp computes it.
T_975 = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160, 2.145,
         2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048,
         2.045, 2.042]


def t_975(df):
    """t(0.975, df): the table to 30, then the Cornish-Fisher expansion in 1/df (Abramowitz and Stegun
    26.7.5), within 1e-6 of the exact quantile there."""
    if df <= len(T_975):
        return T_975[df - 1]
    z = 1.959963984540054
    g1 = (z**3 + z) / 4
    g2 = (5 * z**5 + 16 * z**3 + 3 * z) / 96
    g3 = (3 * z**7 + 19 * z**5 + 17 * z**3 - 15 * z) / 384
    g4 = (79 * z**9 + 776 * z**7 + 1482 * z**5 - 1920 * z**3 - 945 * z) / 92160
    return z + g1 / df + g2 / df**2 + g3 / df**3 + g4 / df**4


def samples_of(text):
    """The positive numbers of a *_samples field ("12.5;12.7;12.4"); none for an empty one."""
    values = []
    for item in str(text).split(";"):
        try:
            v = float(item)
        except ValueError:
            continue
        if v > 0 and math.isfinite(v):
            values.append(v)
    return values


def geometric_interval(samples):
    """(low, high) of the 95% interval of the geometric mean of `samples` (Student's t on their logs, as
    harness/report/ratio_stats.h does for ratios), or None with fewer than two."""
    if len(samples) < 2:
        return None
    logs = [math.log(v) for v in samples]
    mean = sum(logs) / len(logs)
    sd = math.sqrt(sum((x - mean) ** 2 for x in logs) / (len(logs) - 1))
    df = len(logs) - 1
    half = t_975(df) * sd / math.sqrt(len(logs))
    return math.exp(mean - half), math.exp(mean + half)


def readable_log_ticks(axis, low, high):
    """Log axis labelled with plain numbers and enough of them: every integer multiple of a power of ten
    for a range under a decade, 1-2-5 up to two decades, powers of ten beyond."""
    decades = math.log10(high / low) if low > 0 and high > low else 0.0
    subs = tuple(range(1, 10)) if decades < 1 else (1.0, 2.0, 5.0) if decades < 2.5 else (1.0,)
    axis.set_major_locator(ticker.LogLocator(base=10, subs=subs, numticks=30))
    axis.set_major_formatter(ticker.FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_locator(ticker.LogLocator(base=10, subs=tuple(range(1, 10)), numticks=30))
    axis.set_minor_formatter(ticker.NullFormatter())


def pareto_front(points):
    """Indices of the points no other point dominates: (time, rate) with less or equal time and more or
    equal rate, and better in one of them."""
    front = []
    for i, (t, r) in enumerate(points):
        if not any((t2 <= t and r2 >= r) and (t2 < t or r2 > r) for j, (t2, r2) in enumerate(points) if j != i):
            front.append(i)
    return sorted(front, key=lambda i: points[i][0])


def text_box(text, renderer):
    """The box of an annotation's text alone (Annotation.get_window_extent includes its leader line)."""
    return matplotlib.text.Text.get_window_extent(text, renderer)


def spread_labels(ax, texts, iterations=200, pad=1.5, reach=60.0):
    """Moves annotation labels (offsets in points from their anchors) apart until their text boxes stop
    overlapping: each round pushes every overlapping pair apart, half the overlap each, along the axis
    where they overlap least, and keeps each label within `reach` points of its point and inside the
    axes. A simple form of the repulsion of force-directed label placers (Christensen, Marks and Shieber
    1995, "An empirical study of algorithms for point-feature label placement", ACM TOG 14(3))."""
    if not texts:
        return
    fig = ax.figure
    renderer = fig.canvas.get_renderer()
    scale = fig.dpi / 72.0  # pixels per point
    frame = ax.get_window_extent(renderer)

    def clamp(k):
        x, y = texts[k].xyann
        x, y = max(-reach, min(reach, x)), max(-reach, min(reach, y))
        texts[k].xyann = (x, y)
        box = text_box(texts[k], renderer)
        # Back inside the axes where the label sticks out.
        dx = max(0.0, frame.x0 - box.x0) - max(0.0, box.x1 - frame.x1)
        dy = max(0.0, frame.y0 - box.y0) - max(0.0, box.y1 - frame.y1)
        if dx or dy:
            texts[k].xyann = (x + dx / scale, y + dy / scale)

    for k in range(len(texts)):
        clamp(k)
    for _ in range(iterations):
        boxes = [text_box(t, renderer).padded(pad * scale) for t in texts]
        moved = False
        for i in range(len(texts)):
            for j in range(i + 1, len(texts)):
                a, b = boxes[i], boxes[j]
                dx = min(a.x1, b.x1) - max(a.x0, b.x0)
                dy = min(a.y1, b.y1) - max(a.y0, b.y0)
                if dx <= 0 or dy <= 0:
                    continue
                moved = True
                up = (a.y0 + a.y1) >= (b.y0 + b.y1) if (a.y0 + a.y1) != (b.y0 + b.y1) else i < j
                right = (a.x0 + a.x1) >= (b.x0 + b.x1)
                if dy <= dx * 2:  # labels are wide and short: prefer stacking them
                    step = (dy / 2 + 0.5) / scale * (1 if up else -1)
                    shift = ((0, step), (0, -step))
                else:
                    step = (dx / 2 + 0.5) / scale * (1 if right else -1)
                    shift = ((step, 0), (-step, 0))
                for k, (sx, sy) in zip((i, j), shift):
                    x, y = texts[k].xyann
                    texts[k].xyann = (x + sx, y + sy)
                    clamp(k)
                boxes[i] = text_box(texts[i], renderer).padded(pad * scale)
                boxes[j] = text_box(texts[j], renderer).padded(pad * scale)
        if not moved:
            break


def labels_overlap(ax, texts):
    """Whether any two labels' text boxes overlap (the test checks the figures with it)."""
    renderer = ax.figure.canvas.get_renderer()
    boxes = [text_box(t, renderer) for t in texts]
    return any(boxes[i].overlaps(boxes[j]) for i in range(len(boxes)) for j in range(i + 1, len(boxes)))


def plot_pareto(data, out_dir, stem):
    need = ["scene", "builder", "layout", "ray_set", "trace_mrays_median"]
    if not has(data, need) or not ("build_layout_ms_median" in data.columns or "build_ms_median" in data.columns):
        missing = [c for c in need + ["build_layout_ms_median"] if c not in data.columns]
        return log("pareto: skipped, missing columns " + ", ".join(missing))
    rows = data.copy()
    # Build + layout compile; Embree's build does both, and older CSVs have the build alone.
    time = rows["build_layout_ms_median"] if "build_layout_ms_median" in rows.columns else rows["build_ms_median"]
    if "build_ms_median" in rows.columns:
        time = time.fillna(rows["build_ms_median"])
    rows = rows.assign(_time=time)
    rows = rows.dropna(subset=["_time", "trace_mrays_median"])
    rows = rows[(rows["_time"] > 0) & (rows["trace_mrays_median"] > 0)]
    if "frame" in rows.columns:  # animation frames have plots of their own
        rows = rows[rows["frame"].fillna(0) == 0]
    if rows.empty:
        return log("pareto: skipped, no rows with build + layout time and rays/s")
    labels = builder_labels(rows)
    threads = rows["threads"] if "threads" in rows.columns else pd.Series([1] * len(rows), index=rows.index)
    rows = rows.assign(_threads=threads.fillna(1).astype(int))
    written = []
    for (scene, nthreads), group in rows.groupby(["scene", "_threads"], sort=False):
        ray_sets = list(dict.fromkeys(group["ray_set"]))
        cols = min(len(ray_sets), 2)
        nrows = math.ceil(len(ray_sets) / cols)
        fig, axes = plt.subplots(nrows, cols, figsize=(6.5 * cols, 5.0 * nrows), squeeze=False)
        for i, ray_set in enumerate(ray_sets):
            ax = axes[i // cols][i % cols]
            subset = group[group["ray_set"] == ray_set].reset_index(drop=True)
            xs, ys, xerr, yerr, names = [], [], [[], []], [[], []], []
            for _, r in subset.iterrows():
                x, y = r["_time"], r["trace_mrays_median"]
                xi = geometric_interval(samples_of(r.get("build_layout_ms_samples", "")))
                yi = geometric_interval(samples_of(r.get("trace_mrays_samples", "")))
                if yi is None and "trace_mrays_min" in subset.columns and pd.notna(r.get("trace_mrays_min")):
                    yi = (r["trace_mrays_min"], r["trace_mrays_max"])
                if xi is None and "build_ms_min" in subset.columns and pd.notna(r.get("build_ms_min")) \
                        and "build_layout_ms_median" not in subset.columns:
                    xi = (r["build_ms_min"], r["build_ms_max"])
                xs.append(x)
                ys.append(y)
                # Error bars around the median; an interval of the mean that misses it is widened to it.
                xerr[0].append(max(0.0, x - min(xi[0], x)) if xi else 0.0)
                xerr[1].append(max(0.0, max(xi[1], x) - x) if xi else 0.0)
                yerr[0].append(max(0.0, y - min(yi[0], y)) if yi else 0.0)
                yerr[1].append(max(0.0, max(yi[1], y) - y) if yi else 0.0)
                names.append(f"{labels[(r['builder'], r['builder_params'])]} / {r['layout']}")
            front = set(pareto_front(list(zip(xs, ys))))
            for k in range(len(xs)):
                embree = is_embree(subset["builder"].iloc[k])
                on_front = k in front
                ax.errorbar(xs[k], ys[k], xerr=[[xerr[0][k]], [xerr[1][k]]], yerr=[[yerr[0][k]], [yerr[1][k]]],
                            fmt="*" if embree else "o", markersize=10 if embree else 6,
                            color="C3" if embree else ("C0" if on_front else "0.55"),
                            markeredgecolor="black", markeredgewidth=0.5, elinewidth=0.8, capsize=2, zorder=3)
            ordered = sorted(front, key=lambda k: xs[k])
            ax.plot([xs[k] for k in ordered], [ys[k] for k in ordered], color="C0", linewidth=1.0, zorder=2,
                    drawstyle="steps-post", label="Pareto front")
            ax.set_xscale("log")
            ax.set_yscale("log")
            pad = 1.25  # a quarter more on each side, room for the labels
            ax.set_xlim(min(xs) / pad, max(xs) * pad)
            ax.set_ylim(min(ys) / pad, max(ys) * pad)
            readable_log_ticks(ax.xaxis, min(xs) / pad, max(xs) * pad)
            readable_log_ticks(ax.yaxis, min(ys) / pad, max(ys) * pad)
            ax.set_xlabel("build + layout time (ms, median)")
            ax.set_ylabel("Mrays/s (median)")
            ax.set_title(f"{ray_set} rays", fontsize=9)
            ax.grid(True, which="major", alpha=0.35)
            ax.grid(True, which="minor", alpha=0.12)
            texts = [ax.annotate(name, (x, y), xytext=(6, 6), textcoords="offset points", fontsize=6.5,
                                 arrowprops=dict(arrowstyle="-", color="0.5", linewidth=0.5), zorder=4)
                     for name, x, y in zip(names, xs, ys)]
            fig.canvas.draw()
            spread_labels(ax, texts)
            ax.legend(fontsize=7, loc="lower left")
        for k in range(len(ray_sets), nrows * cols):
            axes[k // cols][k % cols].axis("off")
        fig.suptitle(f"{scene}, {nthreads} thread{'s' if nthreads != 1 else ''}: build + layout time against "
                     f"rays/s (upper left is better; stars: Embree; bars: 95% intervals)\n"
                     f"{caption(group)}", fontsize=10)
        fig.tight_layout()
        written += save(fig, out_dir, stem, "pareto", f"{scene}_t{nthreads}")
    return written


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
                 f"({', '.join(list(dict.fromkeys(rows['scene']))[:4])}"
                 f"{', ...' if rows['scene'].nunique() > 4 else ''}) "
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
    # One panel per tree arity and SAH cost model: 8-wide trees' costs (with block SAH) and binary trees'
    # are on other scales, as are costs under other traversal and intersection constants.
    def arity_of(r):
        arity = dict(split_params(r["builder_params"])).get("arity")
        if arity is None and "arity" in binned.columns and pd.notna(r.get("arity")):
            arity = int(r["arity"])
        return int(arity) if arity is not None else 2

    def model_of(r):
        parts = []
        for column, name in (("sah_c_trav", "c_trav"), ("sah_c_isect", "c_isect"), ("sah_block", "block")):
            if column in binned.columns and pd.notna(r.get(column)):
                parts.append(f"{name}={r[column]:g}")
        return ", ".join(parts)

    binned = binned.assign(_arity=[arity_of(r) for _, r in binned.iterrows()],
                           _model=[model_of(r) for _, r in binned.iterrows()])
    panels = list(dict.fromkeys(zip(binned["_arity"], binned["_model"])))
    panels.sort(key=lambda p: (p[0], p[1]))
    cols = min(len(panels), 3)
    nrows = math.ceil(len(panels) / cols)
    fig, axes = plt.subplots(nrows, cols, figsize=(5.2 * cols, 4.0 * nrows), squeeze=False)
    for i, (arity, model) in enumerate(panels):
        ax = axes[i // cols][i % cols]
        subset = binned[(binned["_arity"] == arity) & (binned["_model"] == model)]
        rests = list(dict.fromkeys(zip(subset["scene"], subset["builder"], subset["_rest"])))
        varying = {k for r in rests for k, v in split_params(r[2])
                   if len({dict(split_params(x[2])).get(k) for x in rests if x[1] == r[1]}) > 1}
        many_scenes = subset["scene"].nunique() > 1
        for scene, builder, rest in rests:
            line = subset[(subset["scene"] == scene) & (subset["builder"] == builder) & (subset["_rest"] == rest)]
            line = line.groupby("_bins")["sah_cost"].first().sort_index()
            extra = ";".join(f"{k}={v}" for k, v in split_params(rest) if k in varying)
            name = (f"{scene}: " if many_scenes else "") + builder + (f" [{extra}]" if extra else "")
            color = ax.plot(line.index, line.values, marker="o", label=name)[0].get_color()
            if arity == 2:  # the full sweep is a binary builder: its cost is the binned ones' limit
                sweep = rows[(rows["scene"] == scene) & (rows["builder"] == "sweep_sah")]["sah_cost"]
                if not sweep.empty:
                    ax.axhline(sweep.iloc[0], color=color, linestyle="--", linewidth=0.8,
                               label=(f"{scene}: " if many_scenes else "") + "sweep_sah (every split)")
        ax.set_xscale("log", base=2)
        ax.set_xticks(sorted(subset["_bins"].unique()))
        plain_log_ticks(ax.xaxis, locator=False)
        ax.set_xlabel("bins")
        ax.set_ylabel("SAH cost")
        ax.set_title(f"arity {arity}" + (f"; {model}" if model else ""), fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=6.5)
    for k in range(len(panels), nrows * cols):
        axes[k // cols][k % cols].axis("off")
    scenes = list(dict.fromkeys(binned["scene"]))
    fig.suptitle(f"SAH cost against bin count (lower is better) on {', '.join(scenes)}\n{caption(binned)}",
                 fontsize=10)
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
    for plot in (plot_pareto, plot_build_vs_trace, plot_errors_vs_speed, plot_sah_vs_bins, plot_refit_vs_rebuild):
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
