#!/usr/bin/env bash
# A large OBJ mesh through the `twinray` command: writes the benchmark blob of N
# triangles (default 5e7) as an OBJ file, or takes FILE.obj, then renders a scene that
# names it at 1920x1080 in fresh processes, on the CPU backend and on OpenCL, in float
# and double. Each render's summary line gives its load (reading the OBJ), pack (BVH
# build), render and total times and the process's peak memory, under the loader's
# default limits, which follow the machine's memory.
#   bash bench/large_mesh.sh [N | FILE.obj] [FOLDER] [TWINRAY]
# FOLDER (default: the system's temporary folder) gets the OBJ (about 45 bytes per
# triangle) and the images; TWINRAY defaults to build/apps/twinray/twinray. A mesh with
# a normal and texture coordinate per corner: `build/bench/obj_load_bench --triangles
# 4e6 --keep` writes one (its `_vt_vn.obj`).
set -euo pipefail
cd "$(dirname "$0")/.."
n="${1:-5e7}"
dir="${2:-${TMPDIR:-/tmp}/twinray-large-mesh}"
twinray="${3:-build/apps/twinray/twinray}"
mkdir -p "$dir"
obj="$dir/twinray_bench_blob_$n.obj"
case "$n" in *.obj) obj="$(realpath "$n")" ;; esac
if [ ! -s "$obj" ]; then
  # `bench` writes the OBJ of its obj_<N> scene and times one read of it.
  "$twinray" bench "obj_$n" --obj-dir "$dir" --backend cpu --runs 1 \
    --width 320 --height 180 > /dev/null
fi
echo "$(basename "$obj"): $(du -h "$obj" | cut -f1)" >&2
cat > "$dir/large_mesh.json" <<EOF
{
  "twinray": 1,
  "image": { "width": 1920, "height": 1080, "background": [0, 0, 0] },
  "camera": { "projection": "perspective", "position": [4, -1, 5], "look_at": [0, 0, -1],
              "up": [0, -1, 0], "viewplane_height": 6.0 },
  "render": { "spp": 1, "max_depth": 4 },
  "materials": {
    "lime": { "color": [0.5, 0.9, 0.1], "ka": 0.15, "kd": 0.9, "ks": 0.6, "shininess": 65 },
    "floor": { "color": [0.75, 0.1, 0.65], "ka": 0.15, "kd": 0.9, "ks": 0.6, "shininess": 65,
               "glaze": 0.4 }
  },
  "lights": [ { "type": "point", "position": [-2, -2, 1], "intensity": 12 } ],
  "objects": [
    { "type": "mesh", "obj": "$obj", "material": "lime" },
    { "type": "plane", "point": [0, 1, 0], "normal": [0, -1, 0], "material": "floor" }
  ]
}
EOF
for precision in float double; do
  for backend in cpu opencl; do
    "$twinray" render "$dir/large_mesh.json" -o "$dir/large_mesh_${backend}_$precision.pfm" \
      --backend "$backend" --precision "$precision" --quiet
  done
  if cmp -s "$dir/large_mesh_cpu_$precision.pfm" "$dir/large_mesh_opencl_$precision.pfm"; then
    echo "$precision: the CPU and OpenCL images are the same bits"
  else
    echo "$precision: the CPU and OpenCL images differ"
  fi
done
