#!/usr/bin/env bash
# Two `solid` binaries rendering the same dataset in interleaved rounds (issue 44): per run,
# images/s and images/s per core (wall), and CPU ms per image (user + system time of the
# whole process over its images: on a loaded host, what an image costs whatever else runs),
# with the stage times `solid render --json` reports.
#
#   bench/render_ab.sh OLD_SOLID NEW_SOLID ASSETS [ROUNDS] [IMAGES] [-- MORE RENDER FLAGS]
#
# Defaults: 3 rounds of 1219 images of more-objects at 640x480 with --jobs 2 and query
# views, the release configuration's ratio (1M images, 52,447 models x 8 views: 0.42 views
# per image; 512 views of the 64 procedural models here). The first binary of each round
# alternates. Cores: $SOLID_BENCH_CORES (default 2), as --jobs. Run it under `nice` on a
# shared host; the images/s are wall figures and mean something only on a quiet one.
set -euo pipefail
[ $# -ge 3 ] || { sed -n '2,14p' "$0" >&2; exit 2; }
old=$(realpath "$1") new=$(realpath "$2") assets=$3
rounds=${4:-3}
images=${5:-1219}
shift $(($# < 5 ? $# : 5))
[ "${1:-}" = "--" ] && shift
cores=${SOLID_BENCH_CORES:-2}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

run() {  # NAME BINARY [FLAGS]
  local name=$1 bin=$2 out=$work/ds-$1
  shift 2
  rm -rf "$out"
  /usr/bin/time -f "%U %S" -o "$work/time" "$bin" render --assets "$assets" --preset more-objects \
    --images "$images" --jobs "$cores" --out "$out" --json "$@" >"$work/report.json" 2>/dev/null
  local cpu
  cpu=$(awk '{print $1 + $2}' "$work/time")
  jq -r --arg name "$name" --argjson cpu "$cpu" --argjson cores "$cores" '
    def r(n): . * n | round / n;
    .images as $n |
    [$name, .images, (.images / .seconds | r(100)), (.images / .seconds / $cores | r(100)),
     ($cpu * 1000 / .images | r(10))] +
    (.stages as $s | [$s.layout_ms, $s.mask_pass_ms, $s.shading_ms, $s.encoding_ms, $s.writing_ms,
                      $s.query_views_ms] | map(. / $n | r(10))) + [.query_views] |
    map(tostring) | join("\t")' "$work/report.json"
}

printf 'round\tbinary\timages\timages/s\tper core\tcpu ms/image\tlayout\tmask pass\tshading\tencoding\twriting\t'
printf 'query views (wall ms per image, all threads)\tviews\n'
for r in $(seq 1 "$rounds"); do
  if [ $((r % 2)) = 1 ]; then order="old new"; else order="new old"; fi
  for which in $order; do
    bin=$old
    [ "$which" = new ] && bin=$new
    printf '%s\t' "$r"
    run "$which" "$bin" "$@"
  done
done
