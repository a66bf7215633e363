#!/usr/bin/env bash
# glTF input benchmark (issue 20): models/s and output bytes of `solid convert gltf` against
# `gltf-transform draco` (npm @gltf-transform/cli, one process per model, as a user scripts
# it over a corpus), on the same plain GLB inputs, the same cores and the same quantization
# (positions 14, normals 10, texcoords 12). Inputs: make_obj_corpus models converted by
# `solid convert shapenet`, then written back uncompressed (bench/tools/gltf_decompress.mjs).
#
#   bench/gltf_convert_bench.sh [BUILD_DIR] [MODELS] [JOBS]
#
# Needs node and tests/gltf_transform/node_modules (npm ci --prefix tests/gltf_transform).
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
models=${2:-100}
jobs=${3:-$(nproc)}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
modules=$PWD/tests/gltf_transform/node_modules
[ -x "$modules/.bin/gltf-transform" ] || { echo "bench: run npm ci --prefix tests/gltf_transform" >&2; exit 2; }

cmake --build "$build" --target solid make_obj_corpus >/dev/null
"$build/bench/make_obj_corpus" "$work/corpus" --models "$models" >/dev/null
"$build/cli/solid" convert shapenet "$work/corpus" "$work/draco" --jobs "$jobs" >/dev/null
mkdir -p "$work/in"
i=0
for f in $(find "$work/draco/models" -name '*.glb' | sort); do
  i=$((i + 1)); cp "$f" "$work/in/model-$(printf %05d $i).glb"
done
mkdir -p "$work/plain"
# ES modules resolve packages next to the script: run a copy beside a link to the modules.
ln -s "$modules" "$work/node_modules"
cp bench/tools/gltf_decompress.mjs "$work/"
node "$work/gltf_decompress.mjs" "$work/plain" "$work"/in/*.glb
count=$(find "$work/plain" -name '*.glb' | wc -l)
echo "inputs: $count plain GLBs, $(du -sh "$work/plain" | cut -f1), $jobs jobs"

start=$(date +%s.%N)
"$build/cli/solid" convert gltf "$work/plain" "$work/solid" --jobs "$jobs" >/dev/null
solid_s=$(echo "$(date +%s.%N) - $start" | bc)
solid_bytes=$(find "$work/solid/models" -name '*.glb' -printf '%s\n' | awk '{s+=$1} END {print s}')

export GT="$modules/.bin/gltf-transform"
mkdir -p "$work/ref"
start=$(date +%s.%N)
find "$work/plain" -name '*.glb' -print0 | xargs -0 -P "$jobs" -I{} sh -c '
  "$GT" draco "$1" "$2/$(basename "$1")" --quantize-position 14 --quantize-normal 10 --quantize-texcoord 12 >/dev/null' \
  _ {} "$work/ref"
ref_s=$(echo "$(date +%s.%N) - $start" | bc)
ref_bytes=$(find "$work/ref" -name '*.glb' -printf '%s\n' | awk '{s+=$1} END {print s}')
ref_count=$(find "$work/ref" -name '*.glb' | wc -l)

printf '%-24s %10s %12s %14s\n' path seconds models/s output_bytes
printf '%-24s %10.1f %12.2f %14d\n' "solid convert gltf" "$solid_s" "$(echo "$count / $solid_s" | bc -l)" "$solid_bytes"
printf '%-24s %10.1f %12.2f %14d\n' "gltf-transform draco" "$ref_s" "$(echo "$ref_count / $ref_s" | bc -l)" "$ref_bytes"
printf 'speed ratio %.1fx, size ratio %.3f (solid / reference)\n' "$(echo "($count / $solid_s) / ($ref_count / $ref_s)" | bc -l)" \
  "$(echo "$solid_bytes / $ref_bytes" | bc -l)"
