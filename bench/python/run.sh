#!/usr/bin/env bash
# Builds the benchmark's own virtual environment (build/bench-venv), installs the comparators
# listed in requirements.txt and twinray's Python module, then runs raycast_bench.py with the
# arguments given to this script. Without --mesh, the scanned mesh is the Stanford Bunny that the
# pymeshfix wheel ships, read from where pip installed it.
#
#   bash bench/python/run.sh --rays 10000000 --rounds 3 --markdown
#
# Environment: TWINRAY_SRC           source tree to install twinray from (default: this repository)
#              TWINRAY_SKIP_INSTALL=1 keep the twinray already installed in the venv
#              BENCH_VENV            venv folder (default: build/bench-venv)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
venv="${BENCH_VENV:-$root/build/bench-venv}"
src="${TWINRAY_SRC:-$root}"

if [[ ! -x "$venv/bin/python" ]]; then
  echo "run.sh: creating $venv" >&2
  /usr/bin/python3 -m venv "$venv"
fi
py="$venv/bin/python"
"$py" -m pip install --quiet --upgrade pip >&2
"$py" -m pip install --quiet -r "$here/requirements.txt" >&2

if [[ "${TWINRAY_SKIP_INSTALL:-0}" != 1 ]]; then
  if [[ -f "$src/pyproject.toml" ]]; then
    echo "run.sh: building and installing twinray from $src (takes minutes)" >&2
    "$py" -m pip install --no-build-isolation "$src" >&2  # stdout stays the benchmark's
  else
    echo "run.sh: $src has no pyproject.toml; twinray's columns will be skipped" >&2
  fi
fi

mesh_args=()
if [[ " $* " != *" --mesh "* && " $* " != *" --mesh="* ]]; then
  # find_spec locates the package without importing it (its examples module needs pyvista).
  bunny="$("$py" -c 'import importlib.util as u, os
print(os.path.join(os.path.dirname(u.find_spec("pymeshfix").origin), "examples", "StanfordBunny.ply"))' \
    2>/dev/null || true)"
  if [[ -z "$bunny" || ! -f "$bunny" ]]; then
    echo "run.sh: the pymeshfix wheel's StanfordBunny.ply was not found; pass --mesh PATH" >&2
    exit 1
  fi
  mesh_args=(--mesh "$bunny" --mesh-label "Stanford Bunny scan (pymeshfix wheel)")
fi

exec "$py" "$here/raycast_bench.py" "${mesh_args[@]}" "$@"
