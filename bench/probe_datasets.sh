#!/usr/bin/env bash
# The probes of issue 23 at scale, as a hostile user runs them, with the counts printed.
# Not a ctest: it takes minutes.
#
#   kill        KILLS runs of `solid render` SIGKILLed at random points, then one run that
#               finishes: partial or invalid shards seen after a kill, and whether the
#               finished dataset holds the rows of an undisturbed run (row_xxh64 of every
#               image and instance: every value but the shards' timings).
#   corruption  FLIPS random bit flips and truncations of one shard: how many changed what
#               SQLite returns (or kept it from reading), how many `solid validate` of the
#               shard alone and of the dataset reported, and how many that changed data went
#               unreported (must be 0); then `solid render --repair` of the last damage.
#   full disk   FAULTS runs of render, index and convert with writes failing (ENOSPC) after
#               a random budget (tests/fixtures/fault_inject.c): exit codes, temporaries and
#               catalog -wal/-shm left behind, and reruns that end valid.
#   foreign     a shard of another seed, another shard's file, and a directory in place of
#               a shard: what plain render, index, validate and render --repair do.
#
#   [SOLID=path/to/solid] bench/probe_datasets.sh [BUILD_DIR] [KILLS] [FLIPS] [FAULTS]
# Exit 1 when a probe found a dataset holding what is not its own, a flip that changed data
# unreported, or a fault that left something partial.
set -uo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
kills=${2:-100}
flips=${3:-300}
faults=${4:-30}
solid=${SOLID:-$build/cli/solid}
inject=$build/tests/libsolid_fault_inject.so
[ -n "${SOLID:-}" ] || cmake --build "$build" --target solid solid_fault_inject >/dev/null || exit 1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
bad=0

"$solid" convert procedural "$work/assets" --models 16 --rooms 3 --seed 7 >/dev/null 2>&1
render() {  # [SEED=S] render OUT [flags...]: 18 images in shards of 3 at 64x48, seed 9
  local out=$1
  shift
  "$solid" render --preset random-placement --resolution 64x48 --assets "$work/assets" --out "$out" --images 18 \
    --shard-size 3 --spp 1 --query-size 32 --seed "${SEED:-9}" "$@"
}
# The rows of a dataset: row_xxh64 of every image and instance, sorted.
rows() {
  python3 - "$1" <<'EOF'
import pathlib, sqlite3, sys
out = []
for shard in sorted(pathlib.Path(sys.argv[1], "shards").glob("shard-*.sqlite")):
    db = sqlite3.connect(f"file:{shard}?mode=ro", uri=True)
    out += [f"i{r[0]}:{r[1]}" for r in db.execute("SELECT image_id, row_xxh64 FROM images")]
    out += [f"n{r[0]}:{r[1]}" for r in db.execute("SELECT image_id, row_xxh64 FROM instances")]
print("\n".join(sorted(out)))
EOF
}
leftovers() { find "$1" \( -name '*.tmp-*' -o -name '*-wal' -o -name '*-shm' \) 2>/dev/null | wc -l; }

# --- kill --------------------------------------------------------------------------------
render "$work/reference" --jobs 2 >/dev/null 2>&1 || { echo "reference render failed"; exit 1; }
rows "$work/reference" >"$work/reference.rows"
killed=0 partial=0 invalid=0
for ((i = 0; i < kills; i++)); do
  render "$work/killed" --jobs $((1 + i % 2)) >/dev/null 2>&1 &
  pid=$!
  sleep "0.$(printf '%03d' $((RANDOM % 900 + 50)))"
  if kill -9 "$pid" 2>/dev/null; then killed=$((killed + 1)); fi
  wait "$pid" 2>/dev/null
  partial=$((partial + $(find "$work/killed" -name '*.tmp-*' 2>/dev/null | wc -l)))
  for s in "$work"/killed/shards/shard-*.sqlite "$work"/killed/queries/queries-*.sqlite; do
    [ -e "$s" ] || continue
    "$solid" validate "$s" --no-decode >/dev/null 2>&1 || invalid=$((invalid + 1))
  done
done
render "$work/killed" --jobs 2 >/dev/null 2>&1
finished=$?
same=no
rows "$work/killed" | cmp -s - "$work/reference.rows" && "$solid" validate "$work/killed" >/dev/null 2>&1 && same=yes
echo "kill:       $killed of $kills runs killed; temporaries seen after a kill $partial (a killed writer's own, removed by the next one); published shards invalid $invalid; finishing run exit $finished; the same rows as an undisturbed run: $same"
[ "$invalid" -eq 0 ] && [ "$same" = yes ] || bad=1

# --- corruption --------------------------------------------------------------------------
shard=$work/reference/shards/shard-000002.sqlite
cp "$shard" "$work/pristine.sqlite"
stats=$(python3 - "$solid" "$work/reference" "$shard" "$work/pristine.sqlite" "$flips" <<'EOF'
import random, shutil, sqlite3, subprocess, sys
solid, dataset, shard, pristine, n = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], int(sys.argv[5])
def dump(path):
    try:
        db = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
        db.text_factory = bytes  # a flip may leave text that is no UTF-8
        out = [db.execute("PRAGMA application_id").fetchone(), db.execute("PRAGMA user_version").fetchone()]
        for t in ("sqlite_schema", "shard_meta", "images", "instances"):
            out += list(db.execute(f"SELECT * FROM {t}"))
        db.close()
        return out
    except (sqlite3.DatabaseError, UnicodeDecodeError):  # column names from a damaged schema too
        return None
def fails(*args):
    return subprocess.run([solid, "validate", *args], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode != 0
rng = random.Random(23)
base = open(pristine, "rb").read()
before = dump(pristine)
changed = alone = whole = missed = 0
for i in range(n):
    data = bytearray(base)
    if i % 10 == 9:
        data = data[:rng.randrange(len(data))]
    else:
        at = rng.randrange(len(data))
        data[at] ^= 1 << rng.randrange(8)
    open(shard, "wb").write(data)
    c = dump(shard) != before
    a = fails(shard, "--no-decode")
    w = fails(dataset)
    changed += c; alone += a; whole += w; missed += c and not a
print(changed, alone, whole, missed)
EOF
)
read -r changed alone whole missed <<<"$stats"
render "$work/reference" --repair --jobs 2 >/dev/null 2>&1
repaired=$?
rows "$work/reference" | cmp -s - "$work/reference.rows" && "$solid" validate "$work/reference" >/dev/null 2>&1 && repaired_ok=yes || repaired_ok=no
echo "corruption: $flips damages (1 in 10 a truncation): $changed changed data or made it unreadable; validate of the shard alone reported $alone, of the dataset $whole; changed but unreported $missed; render --repair exit $repaired, rows restored: $repaired_ok"
[ "$missed" -eq 0 ] && [ "$whole" -eq "$flips" ] && [ "$repaired_ok" = yes ] || bad=1

# --- full disk ---------------------------------------------------------------------------
declare -A exits
partial_faults=0 rerun_bad=0
bytes=$(du -sb "$work/reference" | cut -f1)
for ((i = 0; i < faults; i++)); do
  case $((i % 3)) in
    0) what=render; out=$work/fault-render; rm -rf "$out"; cmd=(render "$out" --jobs 2) ;;
    1) what=index; out=$work/fault-index; rm -rf "$out"; cp -r "$work/reference" "$out"; rm -f "$out/index.sqlite"
       cmd=("$solid" index "$out") ;;
    2) what=convert; out=$work/fault-convert; rm -rf "$out"
       cmd=("$solid" convert procedural "$out" --models 12 --rooms 2 --seed 3 --jobs 2) ;;
  esac
  case $what in  # a budget anywhere within what the command writes
    render) budget=$(((RANDOM * 32768 + RANDOM) % bytes + 1)) ;;
    index) budget=$((RANDOM % 60000 + 1)) ;;
    convert) budget=$(((RANDOM * 32768 + RANDOM) % 400000 + 1)) ;;
  esac
  LD_PRELOAD=$inject ASAN_OPTIONS=verify_asan_link_order=0 SOLID_FAULT="write=ENOSPC:$out/*:$budget" \
    "${cmd[@]}" >/dev/null 2>&1
  code=$?
  exits[$what:$code]=$((${exits[$what:$code]:-0} + 1))
  left=$(find "$out" -name '*.tmp-*' 2>/dev/null | wc -l)
  wal=$(find "$out" \( -name '*-wal' -o -name '*-shm' \) 2>/dev/null | wc -l)
  if [ "$left" -gt 0 ]; then partial_faults=$((partial_faults + 1)); fi
  if [ "$wal" -gt 0 ]; then exits[$what:wal-left]=$((${exits[$what:wal-left]:-0} + 1)); fi
  "${cmd[@]}" >/dev/null 2>&1 || rerun_bad=$((rerun_bad + 1))
  if [ "$what" != convert ]; then "$solid" validate "$out" >/dev/null 2>&1 || rerun_bad=$((rerun_bad + 1)); fi
done
summary=$(for k in "${!exits[@]}"; do echo "$k=${exits[$k]}"; done | sort | tr '\n' ' ')
echo "full disk:  $faults faulted runs (command:exit=count, wal-left = a catalog -wal/-shm after the run): $summary; runs leaving a temporary $partial_faults; reruns failing or invalid $rerun_bad"
[ "$partial_faults" -eq 0 ] && [ "$rerun_bad" -eq 0 ] || bad=1

# --- foreign shards ----------------------------------------------------------------------
render "$work/mine" --jobs 2 --no-queries >/dev/null 2>&1
SEED=10 render "$work/other" --jobs 2 --no-queries >/dev/null 2>&1
probe() {  # probe NAME: plain render, index, validate, --repair exit codes
  local r i v p
  render "$work/mine" --jobs 2 --no-queries >/dev/null 2>&1; r=$?
  "$solid" index "$work/mine" >/dev/null 2>&1; i=$?
  "$solid" validate "$work/mine" --no-decode >/dev/null 2>&1; v=$?
  render "$work/mine" --jobs 2 --no-queries --repair >/dev/null 2>&1; p=$?
  "$solid" validate "$work/mine" >/dev/null 2>&1 && ok=valid || ok=INVALID
  echo "foreign:    $1: render exit $r, index exit $i, validate exit $v, render --repair exit $p, then $ok"
  [ "$r" -eq 3 ] && [ "$i" -eq 1 ] && [ "$v" -eq 1 ] && [ "$p" -eq 0 ] && [ "$ok" = valid ] || bad=1
}
cp "$work/other/shards/shard-000001.sqlite" "$work/mine/shards/shard-000001.sqlite"; probe "a seed-10 shard in a seed-9 dataset"
cp "$work/mine/shards/shard-000003.sqlite" "$work/mine/shards/shard-000001.sqlite"; probe "shard 3's file as shard 1"
rm "$work/mine/shards/shard-000002.sqlite"; mkdir "$work/mine/shards/shard-000002.sqlite"
render "$work/mine" --jobs 2 --no-queries >/dev/null 2>&1; r=$?
render "$work/mine" --jobs 2 --no-queries --repair >/dev/null 2>&1; p=$?
"$solid" validate "$work/mine" >/dev/null 2>&1 && ok=valid || ok=INVALID
echo "foreign:    a directory as shard 2: render exit $r, render --repair exit $p, then $ok"
[ "$r" -eq 3 ] && [ "$p" -eq 0 ] && [ "$ok" = valid ] || bad=1
rm "$work/mine/manifest.json"
SEED=10 render "$work/mine" --jobs 2 --no-queries >/dev/null 2>&1; r=$?
SEED=10 render "$work/mine" --jobs 2 --no-queries --adopt >/dev/null 2>&1; a=$?
render "$work/mine" --jobs 2 --no-queries --adopt >/dev/null 2>&1; s=$?
echo "foreign:    manifest.json lost: render --seed 10 exit $r, with --adopt exit $a (the shards say seed 9), render --seed 9 exit $s"
[ "$r" -eq 3 ] && [ "$a" -eq 4 ] && [ "$s" -eq 0 ] || bad=1
exit $bad
