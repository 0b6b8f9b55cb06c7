#!/usr/bin/python3
"""scripts/ab.py against fake sahbench builds that write known CSVs: the medians of ours over Embree
medium per cell and build, the change against the first build with its 95% interval (paired by round),
the samples preferred to the medians, the interleaved order, and clear errors for a failing build, a
missing column and bad arguments.

    test_ab.py PATH/TO/ab.py

Exits 77 (ctest's SKIP_RETURN_CODE) when pandas is not installed.
"""

import stat
import subprocess
import sys
import tempfile
from pathlib import Path

SKIP = 77
failures = []


def check(condition, message):
    if not condition:
        failures.append(message)
        print(f"FAIL: {message}", file=sys.stderr)


# A fake build: `NAME run CONFIG --output PATH` appends NAME to the order log, then writes a CSV where
# Embree's figures change from run to run (a noisy machine) and ours are `scale` times Embree's, so
# that only the ratio is stable. Trace: ours = scale * Embree's rays/s; build: ours = Embree's ms / scale.
FAKE = """#!{python}
import sys, pathlib
name, scale, mode = {name!r}, {scale!r}, {mode!r}
args = sys.argv[1:]
assert args[0] == "run", args
out = pathlib.Path(args[args.index("--output") + 1])
log = pathlib.Path({log!r})
runs = log.read_text().count(name) if log.exists() else 0
with log.open("a") as f:
    f.write(name + "\\n")
if mode == "fail":
    print("error: something broke in the run", file=sys.stderr)
    sys.exit(3)
noise = 1.0 + 0.2 * (runs % 3)
if mode == "wobble":  # ours moves against Embree from run to run: 0.9, 1.1, 0.9, ... times `scale`
    scale *= 0.9 if runs % 2 == 0 else 1.1
columns = ["scene", "builder", "builder_params", "layout", "threads", "ray_set", "trace_mrays_median",
           "build_ms_median"]
if mode == "nocolumn":
    columns.remove("build_ms_median")
# As sahbench writes them: a row per layout and ray set, each carrying its build's time.
rows = [
    ["bunny", "embree", "quality=medium", "embree_1", 1, "shadow", 10.0 * noise, 100.0 * noise],
    ["bunny", "embree", "quality=medium", "embree_8", 1, "shadow", 30.0 * noise, 100.0 * noise],
    # Embree's robust mode: not the anchor, which stays its default mode (a ratio to it would read 1.6).
    ["bunny", "embree", "quality=medium;robust=1", "embree_1", 1, "shadow", 5.0 * noise, 200.0 * noise],
    ["bunny", "wide_collapse", "arity=8", "bvh8", 1, "shadow", 10.0 * noise * scale, 100.0 * noise / scale],
    ["bunny", "wide_collapse", "arity=8", "bvh4", 1, "shadow", 10.0 * noise * scale, 100.0 * noise / scale],
]
if mode == "robustonly":
    rows = [row for row in rows if row[2] != "quality=medium"]
if mode == "embreeonly":  # the anchor, but nothing of ours to compare with it
    rows = [row for row in rows if row[1] == "embree"]
if mode in ("samples", "mismatch"):
    # Samples whose ratios by round are 0.8, 1 and 0.8 (geometric mean 0.862), beside medians that say 1;
    # "mismatch": ours with a fourth round Embree lacks.
    columns += ["trace_mrays_samples", "build_ms_samples"]
    for row in rows:
        ours = row[1] != "embree"
        trace = ("4;10;16" + (";1000" if mode == "mismatch" else "")) if ours else "5;10;20"
        build = "50;80;200" if ours else "40;80;160"
        row[6] = 1.0
        row[7] = 1.0
        row += [trace, build]
if mode == "frames":
    # Frame 1 of an animation, where ours is half Embree's speed (and build time twice Embree's).
    columns += ["frame"]
    second = [list(row) for row in rows]
    for row in second:
        if row[1] != "embree":
            row[6] = row[6] if row[6] == "" else row[6] / 2
            row[7] = row[7] * 2
    rows = [row + [0] for row in rows] + [row + [1] for row in second]
with out.open("w") as f:
    f.write(",".join(columns) + "\\n")
    for row in rows:
        if mode == "nocolumn":
            row = row[:-1]
        f.write(",".join(str(x) for x in row) + "\\n")
"""


def make_build(folder, name, scale, log, mode="ok"):
    path = Path(folder) / name
    path.write_text(FAKE.format(python=sys.executable, name=name, scale=scale, mode=mode, log=str(log)))
    path.chmod(path.stat().st_mode | stat.S_IXUSR)
    return str(path)


def run_ab(ab, *args):
    return subprocess.run([sys.executable, ab, *args], capture_output=True, text=True)


def main():
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    try:
        import pandas  # noqa: F401
    except ImportError:
        print("pandas not installed: skipped", file=sys.stderr)
        return SKIP
    ab = sys.argv[1]
    with tempfile.TemporaryDirectory() as folder:
        config = Path(folder) / "x.toml"
        config.write_text("[experiment]\nname = 'x'\n")
        log = Path(folder) / "order.log"
        a = make_build(folder, "sahbench-a", 0.8, log)
        b = make_build(folder, "sahbench-b", 0.9, log)

        done = run_ab(ab, "--rounds", "3", str(config), a, b)
        check(done.returncode == 0, f"a good A/B exits 0, got {done.returncode}: {done.stderr}")
        out = done.stdout
        trace = [line for line in out.splitlines() if "| bvh8 |" in line or "| bvh4 |" in line]
        build = [line for line in out.splitlines() if "| build |" in line]
        check(len(trace) == 2 and all("| 0.800 | 0.900 | +12.5% [+12.5%, +12.5%] ▲ |" in t for t in trace),
              f"each layout's shadow cell is 0.800 for A and 0.900 for B, +12.5% in every round: {trace}")
        check(len(build) == 1
              and "| wide_collapse | arity=8 | - | 1 | build | 0.800 | 0.900 | +12.5% [+12.5%, +12.5%] ▲ |" in build[0],
              f"one build cell per build, Embree's time over ours, 0.800 and 0.900: {build}")
        rows = [line for line in out.splitlines() if line.startswith("| ") and "| scene |" not in line]
        check(rows and not any(line.startswith("| bunny | embree |") for line in rows),
              f"Embree's own rows are anchors, not cells: {rows}")
        check(f"# A: {a}" in out and f"# B: {b}" in out, "the legend names each build")
        check("# B vs A, trace cells: 2, ▲ 2, ▼ 0, within noise 0; median change +12.5%" in out
              and "# B vs A, build cells: 1, ▲ 1, ▼ 0, within noise 0; median change +12.5%" in out,
              f"a summary line per kind of cell: {out}")
        order = log.read_text().split()
        check(order == ["sahbench-a", "sahbench-b", "sahbench-b", "sahbench-a", "sahbench-a", "sahbench-b"],
              f"rounds alternate the order: {order}")
        check("round 3:" in done.stderr, "progress on stderr names the round")

        # B against A moves 0.9, 1.1, 0.9 times from round to round: a change of -3.8% whose interval,
        # exp(mean +- 4.303 * sd / sqrt(3)) of the logs, holds zero, so no mark.
        wobbly = make_build(folder, "sahbench-w", 0.8, log, mode="wobble")
        done = run_ab(ab, "--rounds", "3", str(config), a, wobbly)
        trace = [line for line in done.stdout.splitlines() if "| bvh8 |" in line]
        check(done.returncode == 0 and len(trace) == 1 and "| -3.8% [-27.8%, +28.3%] |" in trace[0],
              f"a change within the rounds' noise gets a wide interval and no mark: {trace} {done.stderr}")
        done = run_ab(ab, "--rounds", "1", str(config), a, b)
        trace = [line for line in done.stdout.splitlines() if "| bvh8 |" in line]
        check(len(trace) == 1 and "| +12.5% (1 round) |" in trace[0], f"one round has no interval: {trace}")
        check("▲ 0, ▼ 0, within noise 0, 1 of one round; median change +12.5%" in done.stdout,
              f"one round gives no verdict in the summary: {done.stdout}")

        # Samples give 0.862, the geometric mean of 4/5, 10/10 and 16/20 (build: 40/50, 80/80,
        # 160/200), where the medians would give 1.
        sampled = make_build(folder, "sahbench-s", 0.8, log, mode="samples")
        done = run_ab(ab, "--rounds", "2", str(config), sampled, b)
        trace = [line for line in done.stdout.splitlines() if "| bvh8 |" in line]
        build = [line for line in done.stdout.splitlines() if "| build |" in line]
        check(len(trace) == 1 and "| 0.862 | 0.900 |" in trace[0] and len(build) == 1
              and "| 0.862 | 0.900 |" in build[0], f"samples paired by round, not medians: {trace} {build}")

        # Samples of different counts are not paired by round: an error naming the cell, as in report.
        mismatched = make_build(folder, "sahbench-m", 0.8, log, mode="mismatch")
        done = run_ab(ab, "--rounds", "1", str(config), mismatched, b)
        check(done.returncode == 1 and "bunny wide_collapse arity=8 bvh8 1 shadow: 4 samples against the anchor's 3"
              in done.stderr, f"mismatched samples are an error: {done.returncode} {done.stderr}")

        # An animation's frames are cells of their own, each against Embree's same frame.
        framed = make_build(folder, "sahbench-f", 0.8, log, mode="frames")
        done = run_ab(ab, "--rounds", "2", str(config), framed, b)
        frame1 = [line for line in done.stdout.splitlines() if line.startswith("| bunny (frame 1) |")]
        frame0 = [line for line in done.stdout.splitlines() if line.startswith("| bunny |")]
        check(done.returncode == 0 and len(frame1) == 3 and len(frame0) == 3
              and all("| 0.400 | - | - |" in line for line in frame1)
              and all("| 0.800 | 0.900 |" in line for line in frame0),
              f"frames are cells of their own: {done.stdout} {done.stderr}")

        failing = make_build(folder, "sahbench-broken", 1.0, log, mode="fail")
        done = run_ab(ab, "--rounds", "1", str(config), a, failing)
        check(done.returncode == 1, f"a failing build exits 1, got {done.returncode}")
        check("sahbench-broken run" in done.stderr and "exited 3" in done.stderr
              and "something broke" in done.stderr, f"the error names the build and its message: {done.stderr}")

        no_column = make_build(folder, "sahbench-old", 1.0, log, mode="nocolumn")
        done = run_ab(ab, "--rounds", "1", str(config), a, no_column)
        check(done.returncode == 1 and "no column build_ms_median" in done.stderr,
              f"a CSV without a column is an error naming it: {done.returncode} {done.stderr}")

        # Without the anchor, ab.py stops after the first run and says what the config lacks.
        robust_only = make_build(folder, "sahbench-robust", 1.0, log, mode="robustonly")
        before = len(log.read_text().split())
        done = run_ab(ab, "--rounds", "4", str(config), robust_only, b)
        check(done.returncode == 1 and "embree_1 in its default mode (robust = false): add it" in done.stderr
              and len(log.read_text().split()) - before == 1,
              f"no anchor: an error after the first run: {done.returncode} {done.stderr}")
        embree_only = make_build(folder, "sahbench-embree", 1.0, log, mode="embreeonly")
        embree_too = make_build(folder, "sahbench-embree2", 1.0, log, mode="embreeonly")
        before = len(log.read_text().split())
        done = run_ab(ab, "--rounds", "4", str(config), embree_only, embree_too)
        check(done.returncode == 1 and "no cell of round 1 has a ratio" in done.stderr
              and len(log.read_text().split()) - before == 2,
              f"no cell: an error after one round of two runs: {done.returncode} {done.stderr}")

        done = run_ab(ab, str(config), a)
        check(done.returncode == 2 and "at least two builds" in done.stderr, f"one build: {done.stderr}")
        done = run_ab(ab, str(config), a, str(Path(folder) / "missing"))
        check(done.returncode == 2 and "is not an executable file" in done.stderr, f"missing build: {done.stderr}")
        done = run_ab(ab, str(Path(folder) / "nope.toml"), a, b)
        check(done.returncode == 2 and "nope.toml' does not exist" in done.stderr, f"missing config: {done.stderr}")
        done = run_ab(ab, "--rounds", "0", str(config), a, b)
        check(done.returncode == 2 and "--rounds 0" in done.stderr, f"zero rounds: {done.stderr}")

    if failures:
        print(f"ab.py: {len(failures)} checks failed", file=sys.stderr)
        return 1
    print("ab.py: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
