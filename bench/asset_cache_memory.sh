#!/usr/bin/env bash
# The asset cache keeps to its cap (issue 8, "Memory and long runs"): peak RSS of
# `solid render` with `--asset-cache-mb CAP` against a model set whose decoded size is
# several times CAP, next to the same render with the default cap (2048 MiB, which
# holds every model). 160x120, 1 spp, no query views, the more-objects preset.
# Target: peak RSS (capped) <= 2 * CAP + CONSTANT MiB: decoded assets and decoded
# textures each have a cache of CAP, and CONSTANT covers the process itself (code,
# Embree, image buffers, the layouts in flight, shard writing; measured with 1 MiB).
# Exit 1 when the target is missed. Measured (2 jobs, 256 procedural models, 600
# images): peak 320 MiB with the default cap, 243 MiB with 32 MiB, 192 MiB with 1 MiB;
# the constant grows with --jobs (layouts in flight, per-thread buffers).
#
#   [SOLID=path/to/solid] bench/asset_cache_memory.sh [BUILD_DIR] [CAP_MIB] [MODELS] [IMAGES] [CONSTANT_MIB] [JOBS]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
cap=${2:-32}
models=${3:-256}
images=${4:-1000}
constant=${5:-256}
jobs=${6:-$(nproc)}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# $SOLID names a binary to use as is; otherwise BUILD_DIR's is brought up to date.
solid=${SOLID:-$build/cli/solid}
[ -n "${SOLID:-}" ] || cmake --build "$build" --target solid >/dev/null
"$solid" convert procedural "$work/assets" --models "$models" --rooms 8 --seed 1 --jobs "$jobs" >/dev/null
glb_mib=$(du -sm "$work/assets/models" | cut -f1)

# Exit status 1 only says that some layouts were left out.
peak() {
  local report rc=0
  report=$("$solid" render --preset more-objects --resolution 160x120 --spp 1 --no-queries --seed 1 \
    --jobs "$jobs" --asset-cache-mb "$1" --assets "$work/assets" --out "$work/ds-$1" --images "$images" --json \
    2>/dev/null) || rc=$?
  ((rc <= 1)) || { echo "bench: solid render exited $rc" >&2; exit 1; }
  echo "$report" | jq '.peak_rss_bytes / 1048576 | floor'
}
uncapped=$(peak 2048)
capped=$(peak "$cap")
printf '%s models (%s MiB of glb files), %s images, %s jobs\n' "$models" "$glb_mib" "$images" "$jobs"
printf '%-22s %14s\n' "asset cache" "peak RSS MiB"
printf '%-22s %14s\n' "2048 MiB (all models)" "$uncapped"
printf '%-22s %14s\n' "$cap MiB" "$capped"
limit=$((2 * cap + constant))
printf 'capped peak %s MiB, target <= 2 x %s + %s = %s MiB: %s\n' "$capped" "$cap" "$constant" "$limit" \
  "$( ((capped <= limit)) && echo met || echo MISSED)"
((capped <= limit))
