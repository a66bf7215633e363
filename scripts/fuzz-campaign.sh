#!/usr/bin/env bash
# Runs the libFuzzer targets of tests/fuzz (README.md, "Fuzzing"): each target niced, on a
# persistent corpus under WORK/corpora/<target> merged with its seeds (the checked-in
# tests/fuzz/corpus/<target> and the generated ones `fuzz_seeds` writes to WORK/seeds), and
# prints per target: executions, exec/s, coverage (cov, ft), corpus size, CPU seconds and the
# crash, leak, timeout and out-of-memory artifacts found (in WORK/artifacts/<target>/), then
# the slow units (inputs over libFuzzer's 10 s report threshold, below the -t hang limit).
# Exit status 1 when any target crashed, leaked, hung, blew up or did not run, 0 otherwise:
# a slow unit is listed for a person to judge, since wall time on a loaded machine varies.
#
#   scripts/fuzz-campaign.sh [-b BUILD] [-w WORK] [-m MINUTES | -s SECONDS] [-j JOBS]
#                            [-t TIMEOUT_S] [-r RSS_MB] [TARGET...]
#
#   -b  build directory configured with -DSOLID_BUILD_FUZZERS=ON and clang, with the
#       `solid_fuzzers` target built (default build-fuzz)
#   -w  work directory for corpora, seeds, artifacts and logs (default $HOME/solid-fuzz)
#   -m  minutes per target (default 30); -s gives seconds instead
#   -j  targets fuzzed at once, one process each (default 1)
#   -t  seconds after which one input counts as a hang (default 25: wall time, so a loaded
#       machine needs slack; our slowest inputs take well under a second)
#   -r  RSS limit in MB; one input beyond it counts as a memory blowup (default 2048)
#   TARGET  obj glb rle image params search_space manifest shard query_shard index catalog
#           (default: all)
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
all_targets=(obj gltf glb rle image params search_space manifest shard query_shard index catalog)
build=build-fuzz work=${HOME}/solid-fuzz seconds=1800 jobs=1 timeout=25 rss=2048
while getopts "b:w:m:s:j:t:r:h" opt; do
  case $opt in
    b) build=$OPTARG ;;
    w) work=$OPTARG ;;
    m) seconds=$(awk -v m="$OPTARG" 'BEGIN { printf "%d", m * 60 }') ;;
    s) seconds=$OPTARG ;;
    j) jobs=$OPTARG ;;
    t) timeout=$OPTARG ;;
    r) rss=$OPTARG ;;
    *) sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 2 ;;
  esac
done
shift $((OPTIND - 1))
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=("${all_targets[@]}")
build=$(cd "$build" && pwd)
for t in "${targets[@]}"; do
  if [ ! -x "$build/tests/fuzz/${t}_fuzz" ]; then
    echo "fuzz-campaign: $build/tests/fuzz/${t}_fuzz is missing (known targets: ${all_targets[*]});" \
      "build it with: cmake --build $build --target solid_fuzzers" >&2
    exit 2
  fi
done

mkdir -p "$work"
work=$(cd "$work" && pwd)
rm -rf "$work/seeds"
"$build/tests/fuzz/fuzz_seeds" "$work/seeds"

dict_of() {
  case $1 in
    obj) echo "$repo/tests/fuzz/obj.dict" ;;
    glb) echo "$repo/tests/fuzz/glb.dict" ;;
    params | search_space | manifest) echo "$repo/tests/fuzz/json.dict" ;;
  esac
}

# One target: libFuzzer's output goes to WORK/logs/<target>.log, its CPU time to .cpu.
run_target() {
  local t=$1
  local corpus=$work/corpora/$t artifacts=$work/artifacts/$t/ log=$work/logs/$t.log
  mkdir -p "$corpus" "$artifacts" "$work/logs"
  local args=(-max_total_time="$seconds" -timeout="$timeout" -rss_limit_mb="$rss" -print_final_stats=1
              -artifact_prefix="$artifacts")
  local dict
  dict=$(dict_of "$t")
  [ -z "$dict" ] || args+=(-dict="$dict")
  local seeds=()
  for d in "$repo/tests/fuzz/corpus/$t" "$work/seeds/$t"; do
    [ -d "$d" ] && seeds+=("$d")
  done
  /usr/bin/time -f "%U %S" -o "$work/logs/$t.cpu" \
    nice -n 10 "$build/tests/fuzz/${t}_fuzz" "${args[@]}" "$corpus" "${seeds[@]}" >"$log" 2>&1 || true
}

running=0
for t in "${targets[@]}"; do
  rm -f "$work/logs/$t.log" "$work/logs/$t.cpu"
  run_target "$t" &
  running=$((running + 1))
  if [ "$running" -ge "$jobs" ]; then
    wait -n || true
    running=$((running - 1))
  fi
done
wait

status=0
printf '%-13s %12s %8s %7s %7s %7s %9s  %s\n' target executions exec/s cov ft corpus cpu_s findings
for t in "${targets[@]}"; do
  log=$work/logs/$t.log
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -n 1)
  # The last status line ("#N DONE cov: C ft: F corp: U/S ...") has the final coverage.
  last=$(grep -E '^#[0-9]+' "$log" | tail -n 1 || true)
  cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<<"$last")
  ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<<"$last")
  corpus=$(find "$work/corpora/$t" -type f | wc -l)
  cpu=$(tail -n 1 "$work/logs/$t.cpu" 2>/dev/null | awk '{ printf "%.0f", $1 + $2 }')
  findings=$(find "$work/artifacts/$t" -type f \( -name 'crash-*' -o -name 'leak-*' -o -name 'timeout-*' \
    -o -name 'oom-*' \) -newer "$work/seeds" | sort | tr '\n' ' ')
  if [ -z "$execs" ]; then
    findings="${findings}did not finish, see $log"
  fi
  [ -z "$findings" ] || status=1
  printf '%-13s %12s %8s %7s %7s %7s %9s  %s\n' "$t" "${execs:-?}" "${rate:-?}" "${cov:-?}" "${ft:-?}" "$corpus" \
    "$cpu" "${findings:-none}"
done
slow=$(for t in "${targets[@]}"; do
  find "$work/artifacts/$t" -type f -name 'slow-unit-*' -newer "$work/seeds"
done | sort)
[ -z "$slow" ] || printf 'slow units (over 10 s, not failures):\n%s\n' "$slow"
exit $status
