#!/usr/bin/python3
"""`sahbench report --format latex` compiled with pdflatex in a one-column article (--width single), in one
column of a two-column article and of IEEE's two-column conference template, IEEEtran (--width double):
the test fails on any overfull box wider than 1 pt, and prints the width of every table measured by TeX.

    test_latex_fit.py SAHBENCH CSV... [--measure] [--no-width-option]

--measure prints the widths and the overfull boxes without failing (for before/after comparisons);
--no-width-option runs a sahbench without --width (an older build), once, in each document.
Exits 77 (ctest's skip) when pdflatex, booktabs or IEEEtran is missing: scripts/setup.sh installs them
(texlive-latex-base, texlive-latex-recommended, texlive-publishers with texlive-fonts-recommended).

The two-column article's 229.5 pt column is narrower than acmart's 241 pt and IEEEtran's 252 pt, so a
table that fits it fits theirs; IEEEtran is compiled as well, as the template a paper would use. (acmart
needs the Libertine fonts of texlive-fonts-extra, a gigabyte more.)
"""

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

# Each document: its class line, the --width it takes, and the width TeX gives a table there.
DOCUMENTS = {
    "single": (r"\documentclass[10pt]{article}", "single", "textwidth 345.0pt"),
    "double": (r"\documentclass[10pt,twocolumn]{article}", "double", "columnwidth 229.5pt"),
    "ieee": (r"\documentclass[conference]{IEEEtran}", "double", "IEEEtran columnwidth about 252pt"),
}
# TeX reports a box wider than its line as "Overfull \hbox (12.3pt too wide)"; up to 1 pt is invisible.
OVERFULL = re.compile(r"Overfull \\hbox \((\d+(?:\.\d+)?)pt too wide\)")
TOLERANCE_PT = 1.0
WIDTH = re.compile(r"SAHBENCH-WIDTH (\S+) ([\d.]+)pt")


def instrument(tex):
    """Each table's tabular set in box 0 first, so that TeX prints its natural width with its label."""
    out, label = [], "?"
    for line in tex.splitlines():
        match = re.match(r"\s*\\label\{(.+)\}", line)
        if match:
            label = match.group(1)
        if re.match(r"  \\begin\{tabular\}", line):
            line = r"  \setbox0=\hbox{" + line.strip()
        if re.match(r"  \\end\{tabular\}$", line):
            line = line + r"}\typeout{SAHBENCH-WIDTH " + label + r" \the\wd0}\usebox0"
        out.append(line)
        # A long report holds more floats than LaTeX queues (18); widths do not depend on where they go.
        if line.startswith(r"\end{table}"):
            out.append(r"\clearpage")
    return "\n".join(out) + "\n"


def compile_report(tex, width, work):
    doc = work / f"report_{width}.tex"
    doc.write_text(DOCUMENTS[width][0] + "\n\\usepackage{booktabs}\n\\begin{document}\n" + instrument(tex)
                   + "\n\\end{document}\n")
    run = subprocess.run(["pdflatex", "-interaction=nonstopmode", "-halt-on-error", doc.name], cwd=work,
                         capture_output=True, text=True)
    log = (work / f"report_{width}.log").read_text(errors="replace")
    if run.returncode != 0:
        sys.exit(f"test_latex_fit: pdflatex failed on {doc}:\n{run.stdout[-3000:]}")
    widths = [(m.group(1), float(m.group(2))) for m in WIDTH.finditer(log)]
    overfull = [float(m.group(1)) for m in OVERFULL.finditer(log)]
    return widths, overfull


def default_like(source, path):
    """A CSV shaped like configs/default.toml's results from a shipped one: a fourth ray set (ao) and
    wide_collapse rows from two sources, whose labels (source=...) are the longest a default run prints."""
    import csv
    with open(source, newline="") as f:
        reader = csv.DictReader(f)
        columns, rows = reader.fieldnames, list(reader)
    extra = []
    for r in rows:
        if r["ray_set"] == "diffuse":
            extra.append(dict(r, ray_set="ao"))
    for r in rows + extra:
        if r["builder"] == "wide_collapse":
            extra.append(dict(r, builder_params=r["builder_params"].replace("source=binned_sah", "source=sbvh")))
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows + extra)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("sahbench")
    parser.add_argument("csv", nargs="+")
    parser.add_argument("--measure", action="store_true")
    parser.add_argument("--no-width-option", action="store_true")
    parser.add_argument("--default-like", action="store_true",
                        help="also a CSV shaped like configs/default.toml's, made from the first CSV")
    args = parser.parse_args()
    if not shutil.which("pdflatex"):
        print("test_latex_fit: pdflatex missing (scripts/setup.sh installs texlive-latex-base); skipped")
        return 77
    if subprocess.run(["kpsewhich", "booktabs.sty"], capture_output=True, text=True).stdout.strip() == "":
        print("test_latex_fit: booktabs.sty missing (texlive-latex-recommended); skipped")
        return 77
    if subprocess.run(["kpsewhich", "IEEEtran.cls"], capture_output=True, text=True).stdout.strip() == "":
        print("test_latex_fit: IEEEtran.cls missing (texlive-publishers); skipped")
        return 77
    failures = []
    with tempfile.TemporaryDirectory(prefix="sahbench_latex_fit_") as tmp:
        work = Path(tmp)
        csvs = list(args.csv)
        if args.default_like:
            default_like(csvs[0], work / "default_like.csv")
            csvs.append(str(work / "default_like.csv"))
        for csv in csvs:
            for document, (_, width_option, line) in DOCUMENTS.items():
                command = [args.sahbench, "report", csv, "--format", "latex"]
                if not args.no_width_option:
                    command += ["--width", width_option]
                report = subprocess.run(command, capture_output=True, text=True)
                if report.returncode != 0:
                    sys.exit(f"test_latex_fit: {' '.join(command)} failed: {report.stderr}")
                if report.stdout.count(r"\begin{table}") == 0:
                    sys.exit(f"test_latex_fit: {' '.join(command)} wrote no table")
                widths, overfull = compile_report(report.stdout, document, work)
                print(f"{csv} {document} --width {width_option} ({line}): {len(widths)} tables, widths "
                      + ", ".join(f"{w:.1f}" for _, w in widths) + " pt; max "
                      + (f"{max(w for _, w in widths):.1f} pt" if widths else "-")
                      + f"; overfull boxes: {len(overfull)}" + (f" (max {max(overfull):.1f} pt too wide)" if overfull else ""))
                wide = [o for o in overfull if o > TOLERANCE_PT]
                if wide:
                    failures.append(f"{csv} {document} --width {width_option}: {len(wide)} overfull boxes up to {max(wide):.1f} pt")
    for failure in failures:
        print("FAIL:", failure)
    return 0 if args.measure or not failures else 1


if __name__ == "__main__":
    sys.exit(main())
