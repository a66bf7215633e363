#!/usr/bin/env bash
# Soak test of `solid render` (issue 8, "Memory and long runs"): renders IMAGES images
# (default 10,000) at 160x120, 1 sample per pixel, without query views (they are a
# separate pass over the models), in shards of STEP images (default 500), and samples
# the process's VmRSS and VmHWM (/proc/PID/status) each time a shard is published, i.e.
# every STEP images. Prints the curve and checks that VmRSS stays flat after warm-up:
# max / min over the samples from WARMUP images on (default 2000) is below 1.10.
# Not a ctest: it takes minutes. Exit 1 when the curve is not flat. Measured (2 jobs
# on a shared machine, 4 images/s): VmRSS 189.7 MiB at 500 images, 193.3-193.6 MiB
# from 2000 to 10,000 (max/min 1.001).
#
#   [SOLID=path/to/solid] bench/soak_render.sh [BUILD_DIR] [IMAGES] [STEP] [WARMUP] [ASSETS_DIR] [JOBS]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
images=${2:-10000}
step=${3:-500}
warmup=${4:-2000}
assets=${5:-}
jobs=${6:-$(nproc)}
work=$(mktemp -d)
pid=
cleanup() {
  [ -n "$pid" ] && kill "$pid" 2>/dev/null
  rm -rf "$work"
}
trap cleanup EXIT

# $SOLID names a binary to use as is; otherwise BUILD_DIR's is brought up to date.
solid=${SOLID:-$build/cli/solid}
[ -n "${SOLID:-}" ] || cmake --build "$build" --target solid >/dev/null
if [ -z "$assets" ]; then
  assets=$work/assets
  "$solid" convert procedural "$assets" >/dev/null
fi

kib() { awk -v k="$1" '$1 == k":" {print $2}' "/proc/$pid/status" 2>/dev/null || true; }

"$solid" render --preset more-objects --resolution 160x120 --spp 1 --no-queries --shard-size "$step" --seed 1 \
  --jobs "$jobs" --assets "$assets" --out "$work/ds" --images "$images" --json >"$work/report.json" \
  2>"$work/stderr" &
pid=$!
start=$(date +%s.%N)
printf '%8s %8s %12s %12s\n' images seconds "VmRSS MiB" "VmHWM MiB"
: >"$work/curve"
seen=0
while kill -0 "$pid" 2>/dev/null; do
  shards=$({ find "$work/ds/shards" -maxdepth 1 -name 'shard-*.sqlite' 2>/dev/null || true; } | wc -l)
  if ((shards > seen)); then
    seen=$shards
    rss=$(kib VmRSS)
    hwm=$(kib VmHWM)
    [ -z "$rss" ] && break
    done_images=$((shards * step < images ? shards * step : images))
    t=$(awk -v a="$(date +%s.%N)" -v b="$start" 'BEGIN {print a - b}')
    echo "$done_images $rss $hwm" >>"$work/curve"
    awk -v n="$done_images" -v t="$t" -v r="$rss" -v h="$hwm" \
      'BEGIN {printf "%8d %8.1f %12.1f %12.1f\n", n, t, r / 1024, h / 1024}'
  fi
  sleep 0.2
done
rc=0
wait "$pid" || rc=$?
pid=
((rc <= 1)) || { echo "soak: solid render exited $rc" >&2; cat "$work/stderr" >&2; exit 1; }
jq -r '"rendered \(.images) images in \(.seconds | floor) s (\(.images / .seconds | . * 10 | floor / 10) images/s), peak RSS \(.peak_rss_bytes / 1048576 | floor) MiB"' \
  "$work/report.json"
awk -v w="$warmup" '$1 >= w {n++; if (min == "" || $2 < min) min = $2; if ($2 > max) max = $2}
  END {
    if (n < 2) {print "soak: fewer than two samples after warm-up"; exit 1}
    ratio = max / min
    printf "VmRSS after %d images: %d samples, min %.1f MiB, max %.1f MiB, max/min %.3f (target < 1.10)\n",
      w, n, min / 1024, max / 1024, ratio
    exit ratio < 1.10 ? 0 : 1
  }' "$work/curve"
