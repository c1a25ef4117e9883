#!/usr/bin/env bash
# twinray quick start, for a fresh Debian 12 machine as root (README "Quick start").
#   bash scripts/quickstart.sh demo   install what is missing, build, render the demo
#   bash scripts/quickstart.sh test   install what is missing, build, run every test
# .ci/run calls the second; nothing else. Build folder: $TWINRAY_BUILD_DIR or ./build.
set -euo pipefail
cd "$(dirname "$0")/.."
mode="${1:-}"
case "$mode" in demo | test) ;; *)
  echo "usage: bash scripts/quickstart.sh demo|test" >&2
  exit 2
  ;;
esac

# 1. Debian packages that are missing (scripts/packages.txt).
mapfile -t wanted < <(sed -e 's/#.*//' -e '/^[[:space:]]*$/d' scripts/packages.txt)
missing=()
for p in "${wanted[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "quickstart: installing ${missing[*]}" >&2
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# 2. Build.
build="${TWINRAY_BUILD_DIR:-build}"
jobs="$(nproc)"
# clang++ 15, where the CPU backend's float vec3 is a native 3-lane vector as float3 is in
# OpenCL C (docs/performance.md, "The compiler"); CXX chooses another. A folder configured
# before keeps its compiler.
compiler=()
if [ ! -f "$build/CMakeCache.txt" ]; then
  cxx="${CXX:-clang++-15}"
  command -v "$cxx" >/dev/null || cxx=c++
  compiler=(-DCMAKE_CXX_COMPILER="$cxx")
fi
python_tests=()
[ "$mode" = test ] && python_tests=(-DTWINRAY_PYTHON_VENV="$(mkdir -p "$build" && cd "$build" && pwd)/python-venv")
cmake -S . -B "$build" "${compiler[@]}" -DCMAKE_BUILD_TYPE=Release -DTWINRAY_BUILD_BENCHMARKS=ON \
  "${python_tests[@]}" >/dev/null
if [ "$mode" = demo ]; then
  cmake --build "$build" -j "$jobs" --target demo
  mkdir -p out/demo
  "$build/examples/demo" out/demo
  echo "quickstart: the demo images are in out/demo/ (demo.png and the seed's comparisons)"
else
  cmake --build "$build" -j "$jobs"
  # 3. The Python package, built by pip from this checkout into a virtual environment
  # under the build folder (PyPI packages go only there); tests/python runs it.
  venv="$build/python-venv"
  [ -x "$venv/bin/python" ] || /usr/bin/python3 -m venv "$venv"
  "$venv/bin/pip" install -q -r python/requirements-build.txt
  CXX="$(grep -m1 '^CMAKE_CXX_COMPILER:' "$build/CMakeCache.txt" | cut -d= -f2)" \
    "$venv/bin/pip" install -q --no-build-isolation --config-settings=build-dir="$build/python" .
  cd "$build"
  ctest --output-on-failure -j "$jobs"
fi
