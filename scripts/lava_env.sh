#!/usr/bin/env bash
# Build the Python 3.10 virtual environment that runs Intel Lava 0.10.0 (lava-nc), used by
# `cml-edge lava verify` and the tests marked `lava`. Idempotent: a venv that already imports
# lava is left as it is. Location: $CML_EDGE_LAVA_VENV, else .lava-venv/ at the repository root.
# Usage: bash scripts/lava_env.sh   (exit 3: no Python 3.10 interpreter on this machine)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
venv="${CML_EDGE_LAVA_VENV:-$root/.lava-venv}"
if [ -x "$venv/bin/python" ] && "$venv/bin/python" -c "import lava.proc.dense.process" 2>/dev/null; then
  echo "lava venv ready: $venv"
  exit 0
fi
find_python310() {
  local candidate
  if candidate="$(command -v python3.10 2>/dev/null)" && "$candidate" -c "" 2>/dev/null; then
    echo "$candidate"; return 0
  fi
  if command -v pyenv >/dev/null 2>&1; then
    candidate="$(pyenv prefix 3.10 2>/dev/null | head -n1)/bin/python3.10"
    if [ -x "$candidate" ] && "$candidate" -c "" 2>/dev/null; then echo "$candidate"; return 0; fi
  fi
  for candidate in "$HOME"/.pyenv/versions/3.10*/bin/python3.10; do
    if [ -x "$candidate" ] && "$candidate" -c "" 2>/dev/null; then echo "$candidate"; return 0; fi
  done
  return 1
}
if ! py310="$(find_python310)"; then
  echo "lava venv: no Python 3.10 interpreter found (python3.10, pyenv 3.10," \
    "~/.pyenv/versions/3.10*)" >&2
  exit 3
fi
"$py310" -m venv "$venv"
"$venv/bin/python" -m pip install --quiet --upgrade pip
"$venv/bin/python" -m pip install --quiet "lava-nc==0.10.0" "numpy<2" "scipy<1.12" \
  "networkx<=2.8.7" "asteval<0.10"
"$venv/bin/python" -c "import lava.proc.dense.process"
echo "lava venv ready: $venv"
