#!/usr/bin/env bash
# Convert benchmark (issue "Convert"): models/s and output bytes of `solid convert
# shapenet` against SOLID's own path, npm obj2gltf then `gltf-pipeline -d` (Draco), one
# process per model as SOLID's render/data/obj2gltf.sh does, on the same cores and the
# same corpus, at the same quantization (positions 14, normals 10, texcoords 12).
#
#   bench/convert_vs_obj2gltf.sh [BUILD_DIR] [MODELS] [JOBS]
#
# Needs node; uses obj2gltf and gltf-pipeline from $SOLID_BENCH_NODE_MODULES (a node_modules
# folder) if set, else installs them into bench/node_modules with npm.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
models=${2:-300}
jobs=${3:-$(nproc)}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

cmake --build "$build" --target solid make_obj_corpus >/dev/null
modules=${SOLID_BENCH_NODE_MODULES:-$PWD/bench/node_modules}
if [ ! -x "$modules/.bin/obj2gltf" ] || [ ! -x "$modules/.bin/gltf-pipeline" ]; then
  [ -z "${SOLID_BENCH_NODE_MODULES:-}" ] || { echo "bench: no obj2gltf/gltf-pipeline in $modules" >&2; exit 2; }
  npm install --prefix bench --no-audit --no-fund obj2gltf@3.2.0 gltf-pipeline@4.3.1 >/dev/null
fi
"$build/bench/make_obj_corpus" "$work/corpus" --models "$models" >/dev/null
triangles=$(cat "$work"/corpus/*/*/models/model_normalized.obj | grep -c '^f ' || true)
echo "corpus: $models models, $triangles triangles, $(du -sh "$work/corpus" | cut -f1), $jobs jobs"

start=$(date +%s.%N)
"$build/cli/solid" convert shapenet "$work/corpus" "$work/solid" --jobs "$jobs" >/dev/null
solid_s=$(echo "$(date +%s.%N) - $start" | bc)
solid_bytes=$(find "$work/solid/models" -name '*.glb' -printf '%s\n' | awk '{s+=$1} END {print s}')

export OBJ2GLTF="$modules/.bin/obj2gltf" PIPELINE="$modules/.bin/gltf-pipeline"
mkdir -p "$work/ref"
start=$(date +%s.%N)
find "$work/corpus" -name model_normalized.obj -print0 | xargs -0 -P "$jobs" -I{} sh -c '
  id=$(basename "$(dirname "$(dirname "$1")")")
  "$OBJ2GLTF" -i "$1" -o "$2/$id.tmp.glb" >/dev/null &&
  "$PIPELINE" -i "$2/$id.tmp.glb" -o "$2/$id.glb" -d \
    --draco.quantizePositionBits 14 --draco.quantizeNormalBits 10 --draco.quantizeTexcoordBits 12 >/dev/null &&
  rm "$2/$id.tmp.glb"' _ {} "$work/ref"
ref_s=$(echo "$(date +%s.%N) - $start" | bc)
ref_bytes=$(find "$work/ref" -name '*.glb' -printf '%s\n' | awk '{s+=$1} END {print s}')
ref_count=$(find "$work/ref" -name '*.glb' | wc -l)

printf '%-28s %10s %12s %14s\n' path seconds models/s output_bytes
printf '%-28s %10.1f %12.2f %14d\n' "solid convert" "$solid_s" "$(echo "$models / $solid_s" | bc -l)" "$solid_bytes"
printf '%-28s %10.1f %12.2f %14d\n' "obj2gltf + gltf-pipeline -d" "$ref_s" "$(echo "$ref_count / $ref_s" | bc -l)" "$ref_bytes"
printf 'speed ratio %.1fx, size ratio %.3f (solid / reference)\n' "$(echo "($models / $solid_s) / ($ref_count / $ref_s)" | bc -l)" \
  "$(echo "$solid_bytes / $ref_bytes" | bc -l)"
