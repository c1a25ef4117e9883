#!/usr/bin/env bash
# A/B of the device code: the CPU backend of REV against the working tree, frames
# alternated in one process (bench/ab/ab_frames.cpp), each scene in both load orders.
#   bash scripts/ab_device.sh REV [--pairs N] [--threads T] [SCENE...]
# Default scenes: demo mesh_1e4 mesh_1e6 spheres_1e5 spheres_1e6; 8 pairs per order.
# Prints, per scene, new / old in each order and their geometric mean (the figure to
# quote: the module loaded first can gain or lose a few percent), and whether the two
# gave the same image bits. Build folders: $TWINRAY_AB_DIR (default build-ab/).
set -euo pipefail
cd "$(dirname "$0")/.."
if [ $# -lt 1 ]; then
  echo "usage: bash scripts/ab_device.sh REV [--pairs N] [--threads T] [SCENE...]" >&2
  exit 2
fi
rev="$1"
shift
pairs=8
threads=0
scenes=()
while [ $# -gt 0 ]; do
  case "$1" in
  --pairs) pairs="$2"; shift 2 ;;
  --threads) threads="$2"; shift 2 ;;
  *) scenes+=("$1"); shift ;;
  esac
done
[ ${#scenes[@]} -gt 0 ] || scenes=(demo mesh_1e4 mesh_1e6 spheres_1e5 spheres_1e6)
git rev-parse --verify --quiet "$rev^{commit}" >/dev/null || { echo "ab_device: no commit $rev" >&2; exit 2; }

work="${TWINRAY_AB_DIR:-build-ab}"
mkdir -p "$work"
work="$(cd "$work" && pwd)"
# The old side's tree: REV's include/ and apps/, as git has them.
rm -rf "$work/old-tree"
mkdir -p "$work/old-tree"
git archive "$rev" include apps | tar -x -C "$work/old-tree"
configure() { # build folder, side tree
  cmake -S . -B "$1" -DCMAKE_BUILD_TYPE=Release -DTWINRAY_BUILD_BENCHMARKS=ON \
    -DTWINRAY_BUILD_TESTS=OFF -DTWINRAY_BUILD_EXAMPLES=OFF "-DTWINRAY_AB_SIDE_TREE=$2" >/dev/null
}
configure "$work/old" "$work/old-tree"
configure "$work/new" "$(pwd)"
cmake --build "$work/old" --target twinray_ab_side >/dev/null &
old_build=$!
cmake --build "$work/new" --target twinray_ab_side ab_frames >/dev/null
wait "$old_build"
old_so="$work/old/bench/twinray_ab_side.so"
new_so="$work/new/bench/twinray_ab_side.so"
ab="$work/new/bench/ab_frames"

cd "$work"
"$ab" "$old_so" "$new_so" --pairs "$pairs" --threads "$threads" "${scenes[@]}" 2>/dev/null >old_first.csv
"$ab" "$new_so" "$old_so" --pairs "$pairs" --threads "$threads" "${scenes[@]}" 2>/dev/null >new_first.csv
echo "scene,new_over_old_old_loaded_first,new_over_old_new_loaded_first,new_over_old,same_bits"
# Old first: B is new, so B / A is new / old; new first: B / A is old / new.
join -t, <(tail -n +2 old_first.csv | cut -d, -f1,4,9 | sort) \
  <(tail -n +2 new_first.csv | cut -d, -f1,4,9 | sort) |
  awk -F, '{ r1 = $2; r2 = 1 / $4; printf "%s,%.4f,%.4f,%.4f,%s\n", $1, r1, r2, sqrt(r1 * r2),
             ($3 == "yes" && $5 == "yes") ? "yes" : "no" }'
