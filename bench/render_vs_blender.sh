#!/usr/bin/env bash
# Render benchmark (issue "Render"): images/s of `solid render` against Blender Cycles
# rendering the same layouts (`solid sample --export-scene`, lit by the same light rig
# from the scene's extras, bench/tools/blender_render.py) on the same cores in the same
# run, at 640x480 and 320x240; query views/s; `solid render`'s stage breakdown.
#
#   bench/render_vs_blender.sh [BUILD_DIR] [BLENDER_LAYOUTS] [SOLID_IMAGES] [ASSETS_DIR]
#
# Both sides get $SOLID_BENCH_CORES cores (default 2): Cycles as its thread count, solid
# as --jobs (an image per thread). Cycles renders $SOLID_BENCH_SAMPLES samples (default
# 16), fixed (no adaptive sampling) and without a denoiser; solid renders 4 spp at
# 640x480 with its default (adaptive) sampling and with --sampling uniform, and 1 and 4
# spp at 320x240 (adaptive). ASSETS_DIR defaults to `solid convert procedural`.
# $SOLID_BENCH_KEEP=DIR keeps both sides' images there (blender/, solid-WxH-Sspp/).
# Installs Blender with apt-get when it is missing (needs root).
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
layouts=${2:-3}
images=${3:-32}
assets=${4:-}
cores=${SOLID_BENCH_CORES:-2}
samples=${SOLID_BENCH_SAMPLES:-16}
preset=more-objects
seed=1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
keep=${SOLID_BENCH_KEEP:-$work/keep}
mkdir -p "$keep"

cmake --build "$build" --target solid >/dev/null
solid=$build/cli/solid
if ! command -v blender >/dev/null; then
  [ "$(id -u)" = 0 ] || { echo "bench: blender is missing; apt-get install blender as root" >&2; exit 2; }
  apt-get install -y --no-install-recommends blender >/dev/null
fi
if [ -z "$assets" ]; then
  assets=$work/assets
  "$solid" convert procedural "$assets" >/dev/null
fi
echo "blender: $(blender --version 2>/dev/null | head -1); $cores cores; preset $preset, seed $seed"

# The same layouts on both sides: layout i of (preset, seed) at 640x480. At 320x240
# Blender renders the same scenes (same camera and field of view); solid samples its own
# layouts at that size, which may differ where a restart depended on the resolution.
# A layout whose lights find no position is left out of the dataset (and its scene has
# no "lights"): take the first `layouts` that have them.
scenes=()
for ((i = 0; ${#scenes[@]} < layouts; i++)); do
  "$solid" sample --preset "$preset" --resolution 640x480 --seed "$seed" --assets "$assets" \
    --export-scene "$i" --out "$work/scene-$i.glb" 2>/dev/null
  if grep -aq '"lights":' "$work/scene-$i.glb"; then scenes+=("$work/scene-$i.glb"); fi
done
# solid renders at least those layouts, so that its images of them can be looked at.
((images >= i)) || images=$i

start=$(date +%s.%N)
blender -b --factory-startup -noaudio --python bench/tools/blender_render.py -- --out "$keep/blender" \
  --samples "$samples" --threads "$cores" --resolution 640x480 --resolution 320x240 "${scenes[@]}" \
  >"$work/blender.log" 2>&1 || { tail -30 "$work/blender.log" >&2; exit 1; }
blender_process_s=$(echo "$(date +%s.%N) - $start" | bc)
grep -P '^blender\t' "$work/blender.log" | tee "$keep/blender.tsv" >"$work/blender.tsv"
# Mean seconds per image at one resolution: render alone ($5) and with import and save ($6).
blender_mean() { awk -F'\t' -v r="$1" -v c="$2" '$3 == r {s += $c; n++} END {printf "%.3f", s / n}' "$work/blender.tsv"; }

# solid render into a fresh dataset; prints its JSON report. Exit status 1 only says
# that some layouts had no usable lights and were left out, which the report counts.
solid_render() {
  local resolution=$1 spp=$2 n=$3 out=$4 rc=0
  shift 4
  "$solid" render --preset "$preset" --resolution "$resolution" --seed "$seed" --assets "$assets" --out "$out" \
    --images "$n" --spp "$spp" --jobs "$cores" --json "$@" 2>/dev/null || rc=$?
  ((rc <= 1)) || { echo "bench: solid render exited $rc" >&2; exit 1; }
}
# Writes the images of dataset $1 up to id $3 as PNGs into $2, named as Blender's.
extract() {
  mkdir -p "$2"
  sqlite3 "$1/shards/shard-000000.sqlite" \
    "SELECT writefile('$2/scene-' || image_id || '.png', image) FROM images WHERE image_id <= $3" >/dev/null
}

printf '\n%-34s %10s %12s %12s\n' renderer s/image images/s "vs Cycles"
for config in 640x480:4:adaptive 640x480:4:uniform 320x240:1:adaptive 320x240:4:adaptive; do
  IFS=: read -r resolution spp sampling <<<"$config"
  name=$resolution-$spp-$sampling
  report=$(solid_render "$resolution" "$spp" "$images" "$work/ds-$name" --sampling "$sampling" --no-queries)
  echo "$report" >"$work/solid-$name.json"
  extract "$work/ds-$name" "$keep/solid-$resolution-${spp}spp-$sampling" "$((i - 1))"
  solid_rate=$(echo "$report" | jq '.images / .seconds')
  cycles_s=$(blender_mean "$resolution" 5)
  printf '%-34s %10.3f %12.2f %11.1fx\n' "solid render $resolution ${spp} spp $sampling" "$(echo "1 / $solid_rate" | bc -l)" \
    "$solid_rate" "$(echo "$solid_rate * $cycles_s" | bc -l)"
done
for resolution in 640x480 320x240; do
  render_s=$(blender_mean "$resolution" 5)
  total_s=$(blender_mean "$resolution" 6)
  printf '%-34s %10.3f %12.3f\n' "Cycles $resolution $samples spp" "$render_s" "$(echo "1 / $render_s" | bc -l)"
  printf '%-34s %10.3f %12.3f\n' "  with glTF import and PNG save" "$total_s" "$(echo "1 / $total_s" | bc -l)"
done
printf 'Blender process, %d scenes x 2 resolutions, start-up included: %.1f s\n' "$layouts" "$blender_process_s"

# Where solid's time goes (per image, one thread each), from the 640x480 run.
echo
jq -r '.stages as $s | .images as $n | "solid stages at 640x480 4 spp adaptive, ms per image (one thread): " +
  ([$s | to_entries[] | select(.key != "query_views_ms") | "\(.key) \(.value / $n * 100 | round / 100)"] | join(", ")) +
  "; peak RSS \(.peak_rss_bytes / 1048576 | round) MiB"' "$work/solid-640x480-4-adaptive.json"

# Query views: the views of every model the images use, at the images' spp.
report=$(solid_render 640x480 4 "$images" "$work/ds-queries")
echo "$report" | jq -r --argjson cores "$cores" '
  "query views: \(.query_views) views in \(.stages.query_views_ms / 1000 | . * 100 | round / 100) s of one thread: " +
  "\(.query_views / (.stages.query_views_ms / 1000) | . * 10 | round / 10) views/s per thread, " +
  "\(.query_views / (.stages.query_views_ms / 1000) * $cores | . * 10 | round / 10) views/s on \($cores) cores"'
