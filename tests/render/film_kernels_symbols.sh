#!/bin/sh
# The shader's kernel objects (render/film_kernels.h), one per instruction set, define code
# only in their own namespace, solid::render::<set>::. Code they defined elsewhere (an
# inline function or template instance the compiler kept out of line) is a weak symbol
# that other files define too, and the linker keeps one copy for all: an AVX-512 one would
# run on every CPU.
#   film_kernels_symbols.sh OBJECT...
set -eu
[ $# -ge 1 ] || { echo "usage: $0 OBJECT..." >&2; exit 2; }
status=0
for object in "$@"; do
  # The namespace is the one whose kFilmKernels the object defines.
  set_namespace=$(nm -C --defined-only "$object" | sed -n 's/.* [DR] \(solid::render::[a-z0-9_]*\)::kFilmKernels$/\1/p')
  if [ -z "$set_namespace" ]; then
    echo "$object: defines no solid::render::<set>::kFilmKernels" >&2
    status=1
    continue
  fi
  # Text (T), weak (W) and indirect (i) symbols: code the linker may share.
  stray=$(nm -C --defined-only "$object" | grep -E '^[0-9a-f]* [TWi] ' | grep -vF " $set_namespace::" || true)
  if [ -n "$stray" ]; then
    echo "$object: code outside $set_namespace::" >&2
    echo "$stray" >&2
    status=1
  else
    echo "$object: $set_namespace, no code outside it"
  fi
done
exit $status
