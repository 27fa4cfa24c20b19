#!/usr/bin/env bash
# The README's two commands from a fresh clone in fresh venvs: wall time of each, and the
# venv's size with the core alone, with the rl extra and with the test extra.
#   bash scripts/measure_install.sh [WORKDIR]   (default /tmp/evertgym-install; deleted after)
# Writes nothing in the repository; prints the numbers quoted in docs/install.md.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
work="${1:-/tmp/evertgym-install}"
py="${PYTHON:-python3}"
rm -rf "$work" && mkdir -p "$work"
git clone -q "$repo" "$work/evertgym"
rev="$(git -C "$work/evertgym" rev-parse --short HEAD)"
size() { du -sm "$1" | cut -f1; }

"$py" -m venv "$work/core"
cd "$work/evertgym"
t0=$(date +%s.%N)
( source "$work/core/bin/activate" && pip install -q -e . && evertgym reproduce stiffness >/dev/null )
t1=$(date +%s.%N)
core_mb=$(size "$work/core")
( source "$work/core/bin/activate" && pip install -q -e '.[rl]' )
rl_mb=$(size "$work/core")

"$py" -m venv "$work/test"
t2=$(date +%s.%N)
( source "$work/test/bin/activate" && pip install -q -e . && evertgym reproduce stiffness >/dev/null )
t3=$(date +%s.%N)
( source "$work/test/bin/activate" && pip install -q -e '.[test]' && python -m pytest -q | tail -1 )
t4=$(date +%s.%N)
test_mb=$(size "$work/test")
printf 'commit %s, %s\n' "$rev" "$("$py" --version)"
printf 'command 1 (pip install -e . && evertgym reproduce stiffness): %.0f s, again in the second venv %.0f s\n' "$(echo "$t1 - $t0" | bc)" "$(echo "$t3 - $t2" | bc)"
printf 'command 2 (pip install -e .[test] && python -m pytest -q), after command 1: %.0f s\n' "$(echo "$t4 - $t3" | bc)"
printf 'venv size: core %s MB, core + rl %s MB, core + test %s MB\n' "$core_mb" "$rl_mb" "$test_mb"
rm -rf "$work"
