#!/usr/bin/env bash
# The main job of README.md on the embedded default, with no download: the procedural
# shapes and rooms converted to assets (a rerun converts only what changed). Until
# `solid render` lands (issue: render), the dataset comes from the 2D-shape fixture
# generator of tests/ through the same writer API the renderer will use; the rest is
# the real pipeline tail: index, validate, inspect.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j "$(nproc)" --target solid make_fixture_dataset
out=${1:-out/default}
build/cli/solid convert procedural "$out/assets" --models 64 --rooms 8 --seed 1
build/cli/solid inspect "$out/assets"
rm -rf "$out/dataset"
build/tests/make_fixture_dataset "$out/dataset" --images 200 --shard-size 64 --width 320 --height 240 --depth
build/cli/solid index "$out/dataset"
build/cli/solid validate "$out/dataset"
build/cli/solid inspect "$out/dataset"
