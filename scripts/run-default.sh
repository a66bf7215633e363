#!/usr/bin/env bash
# The main job of README.md on the embedded default, with no download: the procedural
# shapes and rooms converted to assets (a rerun converts only what changed), a 300-image
# dataset of the `more-objects` preset rendered with query views (a rerun renders only
# what is missing), then validated and summarized.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j "$(nproc)" --target solid
out=${1:-out/default}
build/cli/solid convert procedural "$out/assets" --models 64 --rooms 8 --seed 1
build/cli/solid inspect "$out/assets"
build/cli/solid sample --preset more-objects --assets "$out/assets" --layouts 300
build/cli/solid render --preset more-objects --assets "$out/assets" --out "$out/dataset" --images 300 \
  --shard-size 64 --depth
build/cli/solid validate "$out/dataset"
build/cli/solid inspect "$out/dataset"
