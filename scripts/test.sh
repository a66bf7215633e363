#!/usr/bin/env bash
# The test command of README.md: installs dependencies, builds once (warnings as
# errors, AddressSanitizer + UndefinedBehaviorSanitizer) and runs every ctest suite.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh --fuzz
# Khronos glTF-Validator from the npm registry, for the glb and convert tests (they skip, saying
# so, when it cannot be installed).
if [ ! -d tests/gltf_validator/node_modules/gltf-validator ] && command -v npm >/dev/null; then
  npm ci --prefix tests/gltf_validator --no-audit --no-fund --silent >/dev/null 2>&1 ||
    echo "test: could not install npm gltf-validator; glTF validation tests will skip"
fi
# @gltf-transform/cli, which makes the meshopt, quantized, Draco and separate-.bin variants
# of the glTF input tests and is the glTF benchmark's baseline, and obj2gltf, which makes the
# glTF of an OBJ for the OBJ-against-glTF test (they skip, saying so, without them).
if [ ! -d tests/gltf_transform/node_modules/@gltf-transform/cli ] && command -v npm >/dev/null; then
  npm ci --prefix tests/gltf_transform --no-audit --no-fund --silent >/dev/null 2>&1 ||
    echo "test: could not install npm @gltf-transform/cli; the glTF variant tests will skip"
fi
# The Kubernetes API schema for the farm test of the Indexed Job manifest (it skips, saying so,
# without it).
if [ ! -d tests/farm/kubernetes/node_modules/kubernetes-models ] && command -v npm >/dev/null; then
  npm ci --prefix tests/farm/kubernetes --no-audit --no-fund --silent >/dev/null 2>&1 ||
    echo "test: could not install the npm packages of tests/farm/kubernetes; the manifest test will skip"
fi
build=${SOLID_TEST_BUILD_DIR:-build-test}
# -O1 and line tables only (what OSS-Fuzz builds sanitizers with): the build is most of CI's
# time, and tinygltf's implementation alone compiled in 104 s at -O2 -g, 53 s at -O1 -g1.
optimize="-O1 -g1 -DNDEBUG"
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="$optimize" -DCMAKE_C_FLAGS_RELWITHDEBINFO="$optimize" \
  -DSOLID_WERROR=ON -DSOLID_SANITIZE=ON -DSOLID_BUILD_BENCH=ON >/dev/null
cmake --build "$build" -j "$(nproc)"

# Fuzz smoke run: every libFuzzer target 4 s on its seeds (about 50 s in all; clang build of
# the readers only). Long campaigns: scripts/fuzz-campaign.sh (README.md, "Fuzzing").
fuzz_build=${SOLID_FUZZ_BUILD_DIR:-build-fuzz}
CC=clang CXX=clang++ cmake -S . -B "$fuzz_build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only -DNDEBUG" \
  -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only -DNDEBUG" \
  -DSOLID_BUILD_FUZZERS=ON -DSOLID_BUILD_BENCH=OFF >/dev/null
cmake --build "$fuzz_build" -j "$(nproc)" --target solid_fuzzers
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
scripts/fuzz-campaign.sh -b "$fuzz_build" -w "$scratch" -s 4 -t 30

export ASAN_OPTIONS=detect_leaks=1:abort_on_error=0 UBSAN_OPTIONS=print_stacktrace=1

# A user's machine has no ../shared: the tests of optional data (label shared-data) must skip
# there, not fail. Run them against an empty folder first, quietly (their log is printed only
# when the check fails), so that the full suite's summary closes the output.
no_shared="$scratch/no-shared"
mkdir -p "$no_shared"
SOLID_SHARED_TESTDATA=$no_shared ctest --test-dir "$build" -L shared-data --output-on-failure \
  -j "$(nproc)" >"$scratch/no-shared.log" 2>&1 || true
ran=$(grep -cE 'Test +#[0-9]+: ' "$scratch/no-shared.log" || true)
skipped=$(grep -cE 'Test +#[0-9]+: .*\*\*\*Skipped' "$scratch/no-shared.log" || true)
echo "test: without the shared data, $skipped of the $ran shared-data tests skipped"
if [ "$ran" -eq 0 ] || [ "$skipped" -ne "$ran" ]; then
  cat "$scratch/no-shared.log"
  echo "test: every shared-data test must skip without the data, and there must be some" >&2
  exit 1
fi

# Last, so that its summary closes the output. The benchmarks are built (so they cannot rot)
# but never run here: they are slow by design.
ctest --test-dir "$build" --output-on-failure -j "$(nproc)"
