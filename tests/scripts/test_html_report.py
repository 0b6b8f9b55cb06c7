#!/usr/bin/python3
"""`sahbench report --format html` on a shipped CSV, with the figures scripts/plots.py draws from it,
loaded in headless Chromium: the page must have one table per report table and every embedded image
must decode (naturalWidth > 0), with no request outside the file.

    test_html_report.py SAHBENCH PLOTS_PY CSV

A copy of the page gets a script that counts the tables and the decoded images after the load event and
writes the counts into the DOM, which Chromium prints with --dump-dom. Without Chromium (Debian package
`chromium`, which scripts/setup.sh installs) the test checks the same structure with Python's
html.parser and says so: that checks the markup, not that a browser shows it.
"""

import base64
import re
import shutil
import subprocess
import sys
import tempfile
from html.parser import HTMLParser
from pathlib import Path

PROBE = """<script>
window.addEventListener("load", () => {
  const images = [...document.images];
  const decoded = images.filter(i => i.complete && i.naturalWidth > 0).length;
  const pre = document.createElement("pre");
  pre.id = "probe";
  pre.textContent = `PROBE tables=${document.querySelectorAll("table").length} images=${images.length} decoded=${decoded}`;
  document.body.appendChild(pre);
});
</script>
"""


class Structure(HTMLParser):
    def __init__(self):
        super().__init__()
        self.tables, self.images, self.external = 0, [], []

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "table":
            self.tables += 1
        if tag == "img":
            self.images.append(attrs.get("src", ""))
        for key in ("src", "href"):
            if key in attrs and not str(attrs[key]).startswith(("data:", "#")):
                self.external.append(attrs[key])


def chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if shutil.which(name):
            return shutil.which(name)
    return None


def main():
    sahbench, plots, csv = sys.argv[1:4]
    failures = []
    with tempfile.TemporaryDirectory(prefix="sahbench_html_") as tmp:
        tmp = Path(tmp)
        figures = tmp / "figures"
        run = subprocess.run([sys.executable, plots, csv, "--out", str(figures)], capture_output=True, text=True)
        if run.returncode != 0:
            sys.exit(f"test_html_report: plots.py failed: {run.stderr}")
        pngs = sorted(figures.glob("*.png"))
        page = tmp / "report.html"
        run = subprocess.run([sahbench, "report", csv, "--format", "html", "--figures", str(figures), "--output",
                              str(page)], capture_output=True, text=True)
        if run.returncode != 0:
            sys.exit(f"test_html_report: sahbench report failed: {run.stderr}")
        markdown = subprocess.run([sahbench, "report", csv], capture_output=True, text=True).stdout
        expected_tables = len(re.findall(r"^## ", markdown, flags=re.M))
        html = page.read_text()

        structure = Structure()
        structure.feed(html)
        if structure.tables != expected_tables:
            failures.append(f"html.parser: {structure.tables} tables, the Markdown report has {expected_tables}")
        if len(structure.images) != len(pngs) or not pngs:
            failures.append(f"html.parser: {len(structure.images)} images for {len(pngs)} PNG figures")
        for src in structure.images:
            match = re.match(r"data:image/png;base64,(.*)", src)
            if not match or not base64.b64decode(match.group(1)).startswith(b"\x89PNG"):
                failures.append("html.parser: an image is not a base64 PNG data URI")
        if structure.external:
            failures.append(f"html.parser: references outside the page: {structure.external[:3]}")

        browser = chromium()
        if browser:
            probe = tmp / "probe.html"
            probe.write_text(html.replace("</body>", PROBE + "</body>"))
            command = [browser, "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                       "--virtual-time-budget=10000", "--dump-dom", probe.as_uri()]
            run = subprocess.run(command, capture_output=True, text=True, timeout=120)
            match = re.search(r"PROBE tables=(\d+) images=(\d+) decoded=(\d+)", run.stdout)
            if not match:
                failures.append(f"chromium: no probe result (exit {run.returncode}): {run.stderr[-2000:]}")
            else:
                tables, images, decoded = map(int, match.groups())
                print(f"chromium: {tables} tables, {images} images, {decoded} decoded")
                if tables != expected_tables:
                    failures.append(f"chromium: {tables} tables, expected {expected_tables}")
                if images != len(pngs) or decoded != images:
                    failures.append(f"chromium: {decoded} of {images} images decoded, {len(pngs)} figures")
        else:
            print("test_html_report: chromium is not installed: the page's structure was checked with "
                  "html.parser only, not in a browser")
        print(f"{page.stat().st_size} bytes, {structure.tables} tables, {len(structure.images)} images")
    for failure in failures:
        print("FAIL:", failure)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
