#!/usr/bin/env bash
# The method's claim in miniature (issue 40, item 5): does SOLID's label-free pretraining make
# a detector better downstream than random init? Not a ctest: it takes an hour or more.
#
#   bench/pretrain_gain.sh [--solid BIN] [--work DIR] [--pretrain-images N] [--pretrain-iterations N]
#     [--finetune-iterations N] [--seeds "1 2 3"] [--pretrain-run RUN] [--downstream-images N]
#
# (a) pretraining set: the procedural default (64 shapes, 8 rooms, conversion seed 1), the
#     more-objects preset at 320x240 with query views;
# (b) label-free pretraining of the small config on it (`python3 -m solid_data.pretrain`),
#     unless --pretrain-run names a finished run to reuse;
# (c) downstream task: other shapes and rooms (conversion seed 2), other images (render seed 2),
#     400 images (--downstream-images) at 320x240 exported to COCO with the shape's family (chair, table, ...) as its
#     category, split into 200 training and 200 validation images sharing one images directory;
# (d) fine-tuning from RUN/detector.pth and from random init, same iterations, for each seed;
# (e) COCOeval bbox AP and AP50 on the validation images, mean and sample standard deviation
#     per init, printed and written to WORK/gain.md.
# A rerun redoes nothing that is done: convert and render resume, pretraining resumes from its
# checkpoint, and a fine-tuning whose metrics.json matches its init and iterations is kept.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
solid=$repo/build/cli/solid
work=$repo/build/pretrain-gain
pretrain_images=2000
pretrain_iterations=1000
finetune_iterations=300
seeds="1 2 3"
pretrain_run=
downstream_images=400
usage() { sed -n '5,6p' "$0" | sed 's/^# \{0,3\}//' >&2; exit 2; }
while [ $# -gt 0 ]; do
  [ $# -ge 2 ] || usage
  case $1 in
    --solid) solid=$2 ;;
    --work) work=$2 ;;
    --pretrain-images) pretrain_images=$2 ;;
    --pretrain-iterations) pretrain_iterations=$2 ;;
    --finetune-iterations) finetune_iterations=$2 ;;
    --seeds) seeds=$2 ;;
    --pretrain-run) pretrain_run=$2 ;;
    --downstream-images) downstream_images=$2 ;;
    *) usage ;;
  esac
  shift 2
done
python=/usr/bin/python3
[ -x "$solid" ] || { echo "pretrain_gain: no solid binary at $solid (build it, or pass --solid)" >&2; exit 2; }
if [ -n "$pretrain_run" ] && { [ ! -f "$pretrain_run/detector.pth" ] || [ ! -f "$pretrain_run/config.json" ]; }; then
  echo "pretrain_gain: --pretrain-run $pretrain_run has no detector.pth and config.json" >&2
  exit 2
fi
mkdir -p "$work"
work=$(cd "$work" && pwd)
solid=$(cd "$(dirname "$solid")" && pwd)/$(basename "$solid")
coco_path=$("$repo/scripts/build-pycocotools.sh")
export PYTHONPATH="$repo/python:$coco_path${PYTHONPATH:+:$PYTHONPATH}"

started=$SECONDS
load_start=$(uptime)
timings=()
step() {
  [ -n "${step_name:-}" ] && timings+=("$step_name: $((SECONDS - step_began)) s")
  step_name=$1
  step_began=$SECONDS
  printf '\n== %s (%d s)\n' "$1" $((SECONDS - started))
}
echo "pretrain_gain: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//')"
echo "load at start: $load_start"

if [ -n "$pretrain_run" ]; then
  run=$(cd "$pretrain_run" && pwd)
  step "a, b. pretraining: reusing $run"
else
  step "a. pretraining set: procedural default, more-objects at 320x240, $pretrain_images images with query views"
  "$solid" convert procedural "$work/pretrain-assets" --models 64 --rooms 8 --seed 1
  "$solid" render --preset more-objects --resolution 320x240 --assets "$work/pretrain-assets" \
    --out "$work/pretrain-dataset" --images "$pretrain_images" --shard-size 250 --seed 1 --query-size 112
  run=$work/pretrain-$pretrain_iterations
  step "b. pretraining: small config, $pretrain_iterations iterations, into $run"
  "$python" -m solid_data.pretrain --dataset "$work/pretrain-dataset" --config small --out "$run" \
    --set iterations="$pretrain_iterations"
fi

step "c. downstream: other shapes, rooms and images, $downstream_images at 320x240, the family as category"
"$solid" convert procedural "$work/downstream-assets" --models 64 --rooms 8 --seed 2
"$solid" render --preset more-objects --resolution 320x240 --assets "$work/downstream-assets" \
  --out "$work/downstream-dataset" --images "$downstream_images" --shard-size 200 --seed 2 --no-queries
# One category per model, mapped to its family below; the C++ export knows models, not families.
"$solid" export coco "$work/downstream-dataset" "$work/downstream-coco" --categories model --masks visible
"$python" - "$work/downstream-assets/catalog.sqlite" "$work/downstream-coco" "$((downstream_images / 2))" <<'EOF'
import json, sqlite3, sys
from pathlib import Path

catalog, coco, train_count = sys.argv[1], Path(sys.argv[2]), int(sys.argv[3])
db = sqlite3.connect(Path(catalog).resolve().as_uri() + "?mode=ro", uri=True)
family_of = {key: json.loads(extras).get("family")
             for key, extras in db.execute("SELECT key, extras FROM assets WHERE kind = 'model'")}
data = json.loads((coco / "annotations.json").read_text())
model_of = {c["id"]: c["name"] for c in data["categories"]}
unknown = sorted({m for m in model_of.values() if not family_of.get(m)})
if unknown:
    sys.exit(f"pretrain_gain: models without a family in {catalog}: {', '.join(unknown[:5])}")
# Every family of the catalog, present in the images or not: both splits list the same classes.
families = sorted({f for f in family_of.values() if f})
family_id = {f: i + 1 for i, f in enumerate(families)}
categories = [{"id": family_id[f], "name": f, "supercategory": "object"} for f in families]
annotations = [{**a, "category_id": family_id[family_of[model_of[a["category_id"]]]]} for a in data["annotations"]]
images = sorted(data["images"], key=lambda im: im["id"])
splits = {"train": images[:train_count], "val": images[train_count:]}
for name, chosen in splits.items():
    ids = {im["id"] for im in chosen}
    split = {**data, "images": chosen, "categories": categories,
             "annotations": [a for a in annotations if a["image_id"] in ids]}
    (coco / f"{name}.json").write_text(json.dumps(split))
    print(f"{coco / name}.json: {len(chosen)} images, {len(split['annotations'])} boxes, {len(families)} families")
EOF

step "d. fine-tuning, $finetune_iterations iterations, pretrained and scratch, seeds $seeds"
finetunes=$work/finetune-$finetune_iterations-$(basename "$run")
for seed in $seeds; do
  for init in pretrained scratch; do
    out=$finetunes/$init-seed$seed
    init_args=()
    expected=None
    if [ "$init" = pretrained ]; then
      init_args=(--init "$run/detector.pth")
      expected="\"$run/detector.pth\""
    fi
    if [ -f "$out/metrics.json" ] && "$python" -c "
import json, sys; m = json.load(open('$out/metrics.json'))
sys.exit(m['iterations'] != $finetune_iterations or m['init'] != $expected)"; then
      echo "$out: done before, kept"
      continue
    fi
    echo "-- $init, seed $seed"
    "$python" -m solid_data.finetune --config "$run/config.json" "${init_args[@]}" \
      --train-json "$work/downstream-coco/train.json" --train-images "$work/downstream-coco/images" \
      --val-json "$work/downstream-coco/val.json" --val-images "$work/downstream-coco/images" \
      --iterations "$finetune_iterations" --seed "$seed" --log-every 25 --out "$out"
  done
done

step "e. table"
timings+=("$step_name: $((SECONDS - step_began)) s")
load_end=$(uptime)
"$python" - "$finetunes" "$work/gain.md" "$seeds" <<EOF
import json, statistics, sys
from pathlib import Path

finetunes, report, seeds = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3].split()
run = json.loads(Path("$run/run.json").read_text()) if Path("$run/run.json").exists() else {}
config = json.loads(Path("$run/config.json").read_text())
rows = {init: [json.loads((finetunes / f"{init}-seed{s}" / "metrics.json").read_text()) for s in seeds]
        for init in ("pretrained", "scratch")}
lines = ["# SOLID pretraining gain (bench/pretrain_gain.sh)", "",
         f"Pretraining: {config['detector']}, {config['iterations']} iterations of {config['targets_per_batch']} "
         f"targets, run $run ({run.get('annotated_images', '?')} annotated images, {run.get('models', '?')} models). "
         f"Downstream: {rows['scratch'][0]['train_images']} training and {rows['scratch'][0]['val_images']} "
         f"validation images, {rows['scratch'][0]['categories']} families, {rows['scratch'][0]['iterations']} "
         "fine-tuning iterations each.", "",
         "| init | seed | AP | AP50 |", "|---|---|---|---|"]
for init, metrics in rows.items():
    for s, m in zip(seeds, metrics):
        lines.append(f"| {init} | {s} | {100 * m['AP']:.2f} | {100 * m['AP50']:.2f} |")
lines += ["", "| init | AP mean ± std | AP50 mean ± std |", "|---|---|---|"]
summary = {}
for init, metrics in rows.items():
    for stat in ("AP", "AP50"):
        values = [100 * m[stat] for m in metrics]
        summary[init, stat] = (statistics.mean(values), statistics.stdev(values) if len(values) > 1 else 0.0)
    lines.append(f"| {init} | {summary[init, 'AP'][0]:.2f} ± {summary[init, 'AP'][1]:.2f} | "
                 f"{summary[init, 'AP50'][0]:.2f} ± {summary[init, 'AP50'][1]:.2f} |")
lines.append("")
# The spread: the larger of the two inits' sample standard deviations over the seeds.
for stat in ("AP", "AP50"):
    (pm, ps), (sm, ss) = summary["pretrained", stat], summary["scratch", stat]
    gain, spread = pm - sm, max(ps, ss)
    verdict = "beats" if gain > spread else "does NOT beat"
    lines.append(f"{stat}: pretrained {verdict} scratch by more than the spread "
                 f"(gain {gain:+.2f}, spread {spread:.2f}, {len(seeds)} seeds).")
lines += ["", "Machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//').",
          "Load at start: $load_start", "Load at end: $load_end", "",
          "Timings: " + "; ".join("""$(printf '%s\n' "${timings[@]}")""".splitlines()) + "; total $((SECONDS - started)) s."]
text = "\n".join(lines) + "\n"
report.write_text(text)
print(text)
EOF
echo "pretrain_gain: done in $((SECONDS - started)) s; $work/gain.md"
