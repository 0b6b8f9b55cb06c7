#!/usr/bin/env bash
# Fails, naming the files, when a tracked C++ file differs from what clang-format (the root
# .clang-format) makes of it. Installs clang-format when it is missing. `clang-format -i FILE` mends one.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v clang-format >/dev/null 2>&1; then
  sudo_cmd=()
  [[ $(id -u) -eq 0 ]] || sudo_cmd=(sudo)
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get update -qq
  "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends clang-format >/dev/null
fi
unformatted=()
while IFS= read -r -d '' file; do
  clang-format --dry-run -Werror "$file" >/dev/null 2>&1 || unformatted+=("$file")
done < <(git ls-files -z -- '*.cpp' '*.h' '*.inl')
if ((${#unformatted[@]})); then
  printf 'check_format: not formatted with the root .clang-format (clang-format -i FILE):\n' >&2
  printf '  %s\n' "${unformatted[@]}" >&2
  exit 1
fi
echo "check_format: $(git ls-files -- '*.cpp' '*.h' '*.inl' | wc -l) files formatted"
