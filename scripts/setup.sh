#!/usr/bin/env bash
# Installs what sahbench needs (Debian 12 packages) and builds it in build/release.
# Safe to run again: installs only missing packages and rebuilds incrementally.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  cmake ninja-build g++ git pkg-config ccache
  libembree-dev libtbb-dev libtinygltf-dev libtinyobjloader-dev nlohmann-json3-dev
  libopenimageio-dev libcgal-dev libgmp-dev libmpfr-dev libboost-dev
  libbenchmark-dev libgtest-dev libtomlplusplus-dev libcli11-dev libfmt-dev
  python3-matplotlib python3-pandas
  # The report's tests: pdflatex with booktabs compiles the LaTeX tables, in IEEEtran too
  # (tests/scripts/test_latex_fit.py), headless Chromium loads the HTML page (tests/scripts/test_html_report.py).
  texlive-latex-base texlive-latex-recommended texlive-publishers texlive-fonts-recommended chromium
)
preset=${SAHBENCH_PRESET:-release}
# The fuzz preset builds with clang and links libFuzzer (scripts/fuzz.sh).
if [[ $preset == fuzz ]]; then packages+=(clang libclang-rt-14-dev); fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}" >&2
  sudo_cmd=()
  [[ $(id -u) -eq 0 ]] || sudo_cmd=(sudo)
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get update -qq
  "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# Compiles go through ccache, keyed on paths relative to the checkout, so that a second checkout of the
# same sources (a CI clone beside a working tree) reuses the objects. Set SAHBENCH_CCACHE=0 to build
# without it.
launcher=()
if [[ ${SAHBENCH_CCACHE:-1} != 0 ]] && command -v ccache >/dev/null 2>&1; then
  launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=true
fi
cmake --preset "$preset" "${launcher[@]}" >/dev/null
cmake --build --preset "$preset"
