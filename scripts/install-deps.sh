#!/usr/bin/env bash
# Installs everything solid needs to build, test and benchmark on Debian 12.
# Idempotent: packages already present are left alone, and nothing is fetched
# from outside the Debian archive. Run as root (or through sudo).
set -euo pipefail

packages=(
  # toolchain
  g++ cmake ninja-build pkg-config
  # libraries: docs/dependencies.md says what each one does, and where
  libsqlite3-dev libxxhash-dev nlohmann-json3-dev libcli11-dev libfmt-dev
  libopenimageio-dev libdeflate-dev
  libembree-dev libdraco-dev libnlopt-dev libeigen3-dev
  # the reference SOLID zarr store of `solid export zarr`: Blosc compresses its chunks
  libblosc-dev
  # glTF input (`solid convert gltf`): tinygltf reads it, meshoptimizer decodes EXT_meshopt_compression
  libtinygltf-dev libmeshoptimizer-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev json-schema-test-suite assimp-testmodels bc jq
  # headless browser of the report test (tests/export/report_test.cpp)
  chromium
  # the Python reader (python/) and its tests: Debian's python3 with NumPy, Pillow (PNG decoding) and PyTorch
  python3 python3-numpy python3-pil python3-torch
  # pretraining and fine-tuning (python/solid_data/pretrain.py, finetune.py): torchvision's detectors,
  # OpenBLAS (15x the reference BLAS on a Faster R-CNN step), Cython to build pycocotools for COCOeval
  python3-torchvision libopenblas0-pthread cython3 python3-dev
  # the zarr export read back by the ecosystem's own reader (python/tests/test_zarr.py)
  python3-zarr python3-numcodecs
  # the farm tests (tests/farm): a single-node Slurm cluster they start and stop themselves
  slurm-wlm munge
)

# Optional tools (fuzzing with clang and libFuzzer): installed with --fuzz.
if [ "${1:-}" = "--fuzz" ]; then packages+=(clang libclang-rt-14-dev); fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "install-deps: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
