#!/usr/bin/env bash
# Memory stays flat over a render (issue "Render"): the peak RSS of `solid render` after
# SMALL and after LARGE images, each in its own process and dataset, 320x240, 1 spp,
# no query views, shards of 256, so that any per-image growth (textures, shards,
# reports) shows as a ratio. Target: LARGE / SMALL < 1.10.
#
#   bench/render_memory.sh [BUILD_DIR] [SMALL] [LARGE] [ASSETS_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
small=${2:-200}
large=${3:-2000}
assets=${4:-}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

cmake --build "$build" --target solid >/dev/null
solid=$build/cli/solid
if [ -z "$assets" ]; then
  assets=$work/assets
  "$solid" convert procedural "$assets" >/dev/null
fi

# Exit status 1 only says that some layouts were left out (no usable lights).
peak() {
  local report rc=0
  report=$("$solid" render --preset more-objects --resolution 320x240 --spp 1 --no-queries --shard-size 256 \
    --seed 1 --assets "$assets" --out "$work/ds-$1" --images "$1" --json 2>/dev/null) || rc=$?
  ((rc <= 1)) || { echo "bench: solid render exited $rc" >&2; exit 1; }
  echo "$report" | jq '[.peak_rss_bytes, .seconds, .images]'
}
small_report=$(peak "$small")
large_report=$(peak "$large")
printf '%-8s %10s %10s %12s\n' images seconds images/s "peak RSS MiB"
for r in "$small_report" "$large_report"; do
  echo "$r" | jq -r '"\(.[2])\t\(.[1])\t\(.[2] / .[1])\t\(.[0] / 1048576)"' |
    awk -F'\t' '{printf "%-8d %10.1f %10.1f %12.1f\n", $1, $2, $3, $4}'
done
ratio=$(jq -n --argjson a "$small_report" --argjson b "$large_report" '$b[0] / $a[0]')
printf 'peak RSS ratio %d / %d images: %.3f (target < 1.10)\n' "$large" "$small" "$ratio"
