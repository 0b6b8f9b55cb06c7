#!/usr/bin/python3
"""scripts/plots.py on small generated CSVs: every kind of plot whose columns are present is written as
PNG and PDF, a kind whose columns are absent is skipped with a message, bad input fails with one.

    test_plots.py PATH/TO/plots.py

Exits 77 (ctest's SKIP_RETURN_CODE) when matplotlib or pandas is not installed.
"""

import contextlib
import csv
import importlib.util
import io
import sys
import tempfile
from pathlib import Path

SKIP = 77
failures = []


def check(condition, message):
    if not condition:
        failures.append(message)
        print(f"FAIL: {message}", file=sys.stderr)


def load_plots(path):
    spec = importlib.util.spec_from_file_location("plots", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def write_csv(path, rows):
    columns = list(dict.fromkeys(k for r in rows for k in r))
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)


def base_row(**fields):
    row = {"run_id": "r1", "git_commit": "abc", "cpu": "Test CPU", "threads": 1, "scene": "proc:soup",
           "scene_triangles": 100, "frame": 0, "builder_params": "", "ray_count": 1000, "sah_cost": ""}
    row.update(fields)
    return row


def benchmark_rows():
    rows = [base_row(run_id="old", builder="binned_sah", builder_params="bins=8", layout="bvh2", ray_set="primary",
                     build_ms_median=99, trace_mrays_median=1, sah_cost=50)]  # an older run: left out
    for ray_set in ("primary", "shadow"):
        for bins, sah in ((8, 41.0), (16, 40.5), (32, 40.2)):
            for layout in ("bvh2", "bvh2_packed"):
                rows.append(base_row(builder="binned_sah", builder_params=f"bins={bins};max_leaf=8", layout=layout,
                                     ray_set=ray_set, build_ms_median=bins / 4, trace_mrays_median=5 + bins / 8,
                                     sah_cost=sah))
        rows.append(base_row(builder="sweep_sah", builder_params="max_leaf=8", layout="bvh2", ray_set=ray_set,
                             build_ms_median=20, trace_mrays_median=9, sah_cost=40.0))
        rows.append(base_row(builder="embree", builder_params="quality=medium", layout="embree_1", ray_set=ray_set,
                             build_ms_median=6, trace_mrays_median=12))
    return rows


def stress_rows():
    rows = []
    for case in ("sphere_far", "needles"):
        for layout, errors in (("bvh2", 0), ("bvh2:tri=mt", 3), ("bvh2:tri=mt,box=fast", 40)):
            rows.append(base_row(scene=case, builder="binned_sah", layout=layout, ray_set="stress", query="closest",
                                 trace_mrays_median=4 + len(layout) / 10, false_misses=errors, false_hits=0,
                                 wrong_prim=errors // 3, leaks=errors // 2, t_err_ulps_max=errors,
                                 t_err_ulps_mean=errors / 7))
        rows.append(base_row(scene=case, builder="embree", builder_params="robust=1", layout="embree_1",
                             ray_set="stress", query="closest", trace_mrays_median=10, false_misses=0, false_hits=0,
                             wrong_prim=0, leaks=0, t_err_ulps_max=1, t_err_ulps_mean=0.2))
    return rows


def animation_rows():
    rows = []
    for frame in range(4):
        common = dict(scene="proc:wave", frame=frame, layout="bvh2", ray_set="primary")
        rows.append(base_row(builder="binned_sah", builder_params="bins=16", build_ms_median=10, sah_cost=30,
                             trace_mrays_median=5, layout_ms=2, **common))
        rows.append(base_row(builder="refit(binned_sah)", builder_params="bins=16", build_ms_median=1,
                             sah_cost=30 * (1 + frame / 10), trace_mrays_median=5 / (1 + frame / 20),
                             layout_refit_ms=0.5, **common))
        common["layout"] = "embree_1"
        rows.append(base_row(builder="embree", builder_params="quality=medium", build_ms_median=8,
                             trace_mrays_median=9, **common))
        rows.append(base_row(builder="embree", builder_params="quality=refit", build_ms_median=2,
                             trace_mrays_median=8, **common))
    return rows


def run(plots, args):
    """Runs plots.main in this process (one matplotlib import for every case); returns (code, stderr)."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = plots.main([str(a) for a in args])
        except SystemExit as e:
            code = e.code if isinstance(e.code, int) else 1
            print(e.code, file=sys.stderr)
    return code, err.getvalue()


def expect_files(out, names):
    for name in names:
        for ext, magic in (("png", b"\x89PNG"), ("pdf", b"%PDF")):
            path = out / f"{name}.{ext}"
            check(path.is_file() and path.read_bytes()[:4] == magic, f"{path} missing or not a {ext}")


def expect_embedded_fonts(path):
    """Fonts embedded as TrueType (pdf.fonttype 42), no Type 3 font."""
    data = path.read_bytes() if path.is_file() else b""
    check(b"/FontFile2" in data and b"/Subtype /Type3" not in data, f"{path}: fonts not embedded as TrueType")


def check_label_spreading(plots):
    """Labels of points that sit on one another end up apart, and near their points."""
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(4, 3))
    ax.set_xlim(0, 10)
    ax.set_ylim(0, 10)
    points = [(5, 5)] * 4 + [(5.1, 5.1), (2, 2)]
    texts = [ax.annotate(f"label number {i}", p, xytext=(6, 6), textcoords="offset points", fontsize=7)
             for i, p in enumerate(points)]
    fig.canvas.draw()
    check(plots.labels_overlap(ax, texts), "the test's labels should start on one another")
    plots.spread_labels(ax, texts)
    check(not plots.labels_overlap(ax, texts), "spread_labels left labels overlapping")
    check(all(abs(t.xyann[0]) <= 60 and abs(t.xyann[1]) <= 60 for t in texts), "a label moved out of reach")
    plt.close(fig)
    check(plots.pareto_front([(1, 1), (2, 3), (3, 2), (0.5, 0.5), (2, 3)]) == [3, 0, 1, 4],
          "pareto_front keeps the points no other beats in both time and rate")
    low, high = plots.geometric_interval([10.0, 11.0, 12.0])
    check(low < (10 * 11 * 12) ** (1 / 3) < high and low > 7 and high < 15, f"geometric_interval {low} {high}")
    check(plots.geometric_interval([10.0]) is None, "one sample has no interval")


def main():
    try:
        import matplotlib  # noqa: F401
        import pandas  # noqa: F401
    except ImportError as e:
        print(f"SKIPPED: {e.name} is not installed for {sys.executable}")
        return SKIP
    plots = load_plots(sys.argv[1])
    check_label_spreading(plots)
    import pandas as pd
    labels = plots.builder_labels(pd.DataFrame({"builder": ["embree"] * 3, "builder_params": [
        "quality=medium", "quality=medium;robust=1", "quality=high"]}))
    check(labels[("embree", "quality=medium;robust=1")] == "embree [quality=medium;robust=1]"
          and labels[("embree", "quality=medium")] == "embree [quality=medium]",
          f"a parameter some runs lack is a varying one: {labels}")

    files = plots.builder_labels(pd.DataFrame({"builder": ["file"] * 2, "builder_params": [
        "path=a.sbt;path_hash=0x2b5477d10d8a3dff", "path=b.sbt;path_hash=0x0123456789abcdef"]}))
    check(files[("file", "path=a.sbt;path_hash=0x2b5477d10d8a3dff")] == "file [path=a.sbt]",
          f"a file's hash beside its varying path is left out of its label: {files}")
    same_name = plots.builder_labels(pd.DataFrame({"builder": ["file"] * 3, "builder_params": [
        "path=t.sbt;path_hash=0x1", "path=t.sbt;path_hash=0x2", "path=u.sbt;path_hash=0x3"]}))
    check(len(set(same_name.values())) == 3 and same_name[("file", "path=t.sbt;path_hash=0x1")]
          == "file [path=t.sbt;path_hash=0x1]", f"two files of one name keep their hashes: {same_name}")

    # The helpers behind the pairings and the parameter parsing.
    check(plots.bins_of("adaptive_bins=1;bins=32;max_leaf=8") == 32, "bins_of")
    check(plots.bins_of("max_leaf=8") is None, "bins_of without bins")
    check(plots.bins_of("adaptive_bins=4") is None, "bins_of must not read adaptive_bins")
    check(plots.refit_base("refit(binned_sah)", "bins=8") == ("binned_sah", "bins=8"), "refit_base refit(NAME)")
    check(plots.refit_base("embree", "quality=refit") == ("embree", "quality=medium"), "refit_base embree")
    check(plots.refit_base("binned_sah", "bins=8") is None, "refit_base of a build")
    check(plots.short_series("refit(wide_binned_sah)", "arity=8;bins=32;max_leaf=8") == "refit(wide_binned_sah) arity=8",
          "short_series keeps the arity only")
    check(plots.short_series("embree", "quality=refit") == "embree quality=refit", "short_series keeps the quality")
    check(plots.short_series("embree", "quality=medium;robust=1") == "embree quality=medium,robust=1",
          "short_series keeps Embree's robust mode")

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        write_csv(tmp / "bench.csv", benchmark_rows())
        write_csv(tmp / "stress.csv", stress_rows())
        write_csv(tmp / "anim.csv", animation_rows())

        code, err = run(plots, [tmp / "bench.csv"])
        check(code == 0, f"bench.csv: exit {code}: {err}")
        expect_files(tmp, ["bench_pareto_proc_soup_t1", "bench_build_vs_trace_proc_soup_t1", "bench_sah_vs_bins"])
        expect_embedded_fonts(tmp / "bench_pareto_proc_soup_t1.pdf")
        check("errors_vs_speed: skipped" in err and "refit_vs_rebuild: skipped" in err, f"skip messages: {err}")
        check(not list(tmp.glob("bench_errors*")) and not list(tmp.glob("bench_refit*")), "skipped kinds wrote files")

        out = tmp / "plots"
        code, err = run(plots, [tmp / "stress.csv", "--out", out])
        check(code == 0, f"stress.csv: exit {code}: {err}")
        expect_files(out, ["stress_errors_vs_speed"])

        code, err = run(plots, [tmp / "anim.csv", "--out", out])
        check(code == 0, f"anim.csv: exit {code}: {err}")
        expect_files(out, ["anim_refit_vs_rebuild_proc_wave_t1"])

        # Columns of no kind at all: every kind skipped, still a success.
        write_csv(tmp / "bare.csv", [{"run_id": "r", "scene": "s"}])
        code, err = run(plots, [tmp / "bare.csv", "--out", tmp / "bare"])
        check(code == 0 and err.count("skipped") == 5, f"bare.csv: exit {code}: {err}")
        check(not list((tmp / "bare").glob("*.png")), "bare.csv wrote plots")

        # The shipped CSVs: every kind their columns allow is drawn, the others skipped with a message.
        shipped = Path(sys.argv[1]).resolve().parent.parent / "results" / "baselines" / "ci.csv"
        code, err = run(plots, [shipped, "--out", tmp / "shipped"])
        check(code == 0, f"{shipped}: exit {code}: {err}")
        expect_files(tmp / "shipped", ["ci_pareto_proc_sphere_tris_20k_t1", "ci_build_vs_trace_proc_sphere_tris_20k_t1",
                                       "ci_sah_vs_bins"])
        expect_embedded_fonts(tmp / "shipped" / "ci_sah_vs_bins.pdf")
        for kind in ("errors_vs_speed", "refit_vs_rebuild"):
            check(f"{kind}: skipped" in err, f"{shipped}: no skip message for {kind}: {err}")

        # A measured value that is not a positive number is refused, naming file, line and column.
        rows = benchmark_rows()
        rows[1]["trace_mrays_median"] = "-1"
        write_csv(tmp / "negative.csv", rows)
        code, err = run(plots, [tmp / "negative.csv", "--out", tmp / "negative"])
        check(code == 2 and "negative.csv:3: column 'trace_mrays_median': '-1' is not a finite positive number" in err,
              f"a negative rate must fail naming it: exit {code}: {err}")

        code, err = run(plots, [tmp / "missing.csv"])
        check(code != 0 and "missing.csv" in err, f"a missing file must fail naming it: exit {code}: {err}")

    if failures:
        print(f"{len(failures)} failures", file=sys.stderr)
        return 1
    print("plots.py: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
