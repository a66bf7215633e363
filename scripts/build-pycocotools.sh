#!/usr/bin/env bash
# Builds pycocotools (COCOeval, for `python3 -m solid_data.finetune` and its test and benchmark)
# from the COCO API source in ../shared/third_party/cocoapi, which Debian does not package.
#
#   scripts/build-pycocotools.sh [SRC] [DEST]
#   export PYTHONPATH="$(scripts/build-pycocotools.sh)${PYTHONPATH:+:$PYTHONPATH}"
#
# SRC: the cocoapi directory (default $SOLID_COCOAPI, else ../shared/third_party/cocoapi beside
# the repository); DEST: where the built copy goes (default build/pycocotools). Prints the
# directory to put on PYTHONPATH on stdout, everything else on stderr. Rerunning with the same
# source does nothing; exit 2 when the source is absent.
#
# The copy, never the shared source, is adapted to Debian 12: np.float (removed in NumPy 1.24)
# becomes float, and coco.py's matplotlib imports move into showAnns, their only user, since
# Debian's python3 has no matplotlib unless installed and evaluation needs none.
set -euo pipefail
self=$(cd "$(dirname "$0")" && pwd)/$(basename "$0")
repo=$(dirname "$(dirname "$self")")
src=${1:-${SOLID_COCOAPI:-$repo/../shared/third_party/cocoapi}}
dest=${2:-$repo/build/pycocotools}
python=/usr/bin/python3

if [ ! -f "$src/PythonAPI/pycocotools/cocoeval.py" ] || [ ! -f "$src/common/maskApi.c" ]; then
  echo "build-pycocotools: no cocoapi source at $src (expected PythonAPI/pycocotools and common/);" \
       "pass its directory or set SOLID_COCOAPI" >&2
  exit 2
fi
src=$(cd "$src" && pwd)
mkdir -p "$(dirname "$dest")"
dest=$(cd "$(dirname "$dest")" && pwd)/$(basename "$dest")

# The stamp covers the source's bytes and this script's, whose adaptations shape the copy.
digest=$( (cd "$src" && find PythonAPI common license.txt -type f ! -name '*.so' ! -path '*/build/*' -print0 2>/dev/null |
             sort -z | xargs -0 sha256sum; sha256sum < "$self") | sha256sum | cut -d' ' -f1)
if [ -f "$dest/.source-sha256" ] && [ "$(cat "$dest/.source-sha256")" = "$digest" ] &&
   PYTHONPATH="$dest/PythonAPI" "$python" -c "import pycocotools._mask, pycocotools.cocoeval" 2>/dev/null; then
  echo "build-pycocotools: $dest is up to date" >&2
  echo "$dest/PythonAPI"
  exit 0
fi

missing=()
for package in cython3 python3-dev python3-numpy python3-setuptools; do
  dpkg -s "$package" >/dev/null 2>&1 || missing+=("$package")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "build-pycocotools: installing ${missing[*]}" >&2
  sudo=()
  [ "$(id -u)" -eq 0 ] || sudo=(sudo)
  "${sudo[@]}" apt-get install -y --no-install-recommends "${missing[@]}" >&2
fi

# Built beside DEST and moved into place whole: an interrupted build never looks complete.
work="$dest.partial"
rm -rf "$work"
mkdir -p "$work"
cp -r "$src/PythonAPI" "$src/common" "$work/"
[ -f "$src/license.txt" ] && cp "$src/license.txt" "$work/"
rm -rf "$work/PythonAPI/build" "$work"/PythonAPI/pycocotools/_mask*.so "$work/PythonAPI/pycocotools/_mask.c"
"$python" - "$work/PythonAPI/pycocotools" <<'EOF'
import re, sys
from pathlib import Path

root = Path(sys.argv[1])
evaluation = root / "cocoeval.py"
text = evaluation.read_text()
text = re.sub(r"\bnp\.float\b", "float", text)
evaluation.write_text(text)

api = root / "coco.py"
text = api.read_text()
imports = ("import matplotlib.pyplot as plt\n", "from matplotlib.collections import PatchCollection\n",
           "from matplotlib.patches import Polygon\n")
for line in imports:
    if line not in text:
        sys.exit(f"build-pycocotools: {api} has no line {line.strip()!r}; the adaptation needs updating")
    text = text.replace(line, "", 1)
head = "    def showAnns(self, anns, draw_bbox=False):\n"
docstring_end = text.index('        """\n', text.index(head) + len(head) + len('        """\n')) + len('        """\n')
text = text[:docstring_end] + "".join("        " + line for line in imports) + text[docstring_end:]
api.write_text(text)
EOF
(cd "$work/PythonAPI" && "$python" setup.py build_ext --inplace >&2)
rm -rf "$work/PythonAPI/build"
PYTHONPATH="$work/PythonAPI" "$python" -c "
import numpy as np, pycocotools._mask, pycocotools.coco, pycocotools.cocoeval
assert 'np.float)' not in open(pycocotools.cocoeval.__file__).read()"
echo "$digest" > "$work/.source-sha256"
rm -rf "$dest"
mv "$work" "$dest"
echo "build-pycocotools: built $dest (PYTHONPATH=$dest/PythonAPI)" >&2
echo "$dest/PythonAPI"
