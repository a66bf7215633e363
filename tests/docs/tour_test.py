#!/usr/bin/python3
"""Runs every command of README.md's tour, in order, on its tiny setup, so that the tour stays
true: each `$ ` command of the "A tour" section's shell blocks is run (with `solid` the built
binary and the tour's /tmp/doc-* paths in a scratch folder), must exit 0 (`solid optimize`: 0 or
1, a fit that says it missed), and every line of output the README shows must still be printed,
as far as its label goes (the text before its first digit or path: numbers change, labels must
not). Commands on data a user brings are run on stand-ins: the ShapeNet copy is the shared real
models (skipped when absent), the main job's dataset is the tour's own, and the pretraining
runs one iteration. `sbatch` is left to the farm tests (ctest farm.slurm runs those recipes on a
real Slurm cluster)."""

import argparse
import os
import re
import shlex
import subprocess
import sys
import tempfile

TOUR = re.compile(r"^## A tour\n(.*?)^## ", re.S | re.M)
BLOCK = re.compile(r"^```sh\n(.*?)^```", re.S | re.M)


def steps(readme):
    """[(command, [shown output lines])] of the tour's shell blocks, in order. A command runs on
    over lines that end in a backslash or leave a quote open."""
    tour = TOUR.search(readme)
    if not tour:
        sys.exit("tour_test: README.md has no '## A tour' section")
    out = []
    for block in BLOCK.findall(tour.group(1)):
        lines, i, current = block.splitlines(), 0, None
        while i < len(lines):
            line = lines[i]
            if line.startswith("$ "):
                command = line[2:]
                while (command.endswith("\\") or not balanced(command)) and i + 1 < len(lines):
                    i += 1
                    command = command[:-1] + " " + lines[i].strip() if command.endswith("\\") else command + "\n" + lines[i]
                current = (command, [])
                out.append(current)
            elif current is not None and line.strip():
                current[1].append(line)
            i += 1
    return out


def balanced(text):
    try:
        shlex.split(text, comments=True)
        return True
    except ValueError:
        return False


def label(line):
    """What must not change in a shown output line: its text before the first digit or path."""
    m = re.match(r"[^0-9/]*", line.strip())
    return m.group(0).strip()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--solid", required=True)
    ap.add_argument("--readme", required=True)
    ap.add_argument("--shared", default="", help="the shared test data folder (real ShapeNet models); "
                    "$SOLID_SHARED_TESTDATA overrides it, as for the other tests")
    a = ap.parse_args()
    a.shared = os.environ.get("SOLID_SHARED_TESTDATA") or a.shared
    root = os.path.dirname(os.path.abspath(a.readme))
    problems, ran, skipped = [], 0, []
    with tempfile.TemporaryDirectory() as scratch:
        bin_dir = os.path.join(scratch, "bin")
        os.makedirs(bin_dir)
        os.symlink(os.path.abspath(a.solid), os.path.join(bin_dir, "solid"))
        env = dict(os.environ, PATH=bin_dir + os.pathsep + os.environ.get("PATH", ""))
        shapenet = os.path.join(a.shared, "real", "shapenet") if a.shared else ""
        for command, shown in steps(open(a.readme).read()):
            words = shlex.split(command, comments=True)
            if not words:
                continue
            if any(w.startswith("array=$(sbatch") or w == "sbatch" for w in words):
                skipped.append(f"{command.splitlines()[0]} (a Slurm cluster: ctest farm.slurm runs the recipes)")
                continue
            text = command.replace("/tmp/doc-", os.path.join(scratch, "doc-"))
            text = text.replace("out/default/dataset", os.path.join(scratch, "doc-ds"))
            text = text.replace("runs/small", os.path.join(scratch, "runs-small"))
            if "/data/ShapeNetCore.v2" in text:
                if not shapenet or not os.path.isdir(shapenet):
                    skipped.append(f"{command} (no shared real ShapeNet models to stand in for a user's copy)")
                    continue
                text = text.replace("/data/ShapeNetCore.v2", shapenet).replace(" assets/", " " + os.path.join(scratch, "shapenet-assets"))
            if "solid_data.pretrain" in text:
                text += " --set iterations=1 --log-every 1"
            result = subprocess.run(["bash", "-c", text], cwd=root, env=env, stdout=subprocess.PIPE,
                                    stderr=subprocess.STDOUT, text=True, timeout=1200)
            ran += 1
            allowed = (0, 1) if words[:2] == ["solid", "optimize"] else (0,)
            first = command.splitlines()[0]
            if result.returncode not in allowed:
                problems.append(f"{first}: exit {result.returncode}\n{result.stdout[-3000:]}")
                continue
            for line in shown:
                lab = label(line)
                if lab and lab not in result.stdout:
                    problems.append(f"{first}: README shows '{line.strip()}', but '{lab}' is not in its output:\n"
                                    f"{result.stdout[-3000:]}")
    for s in skipped:
        print(f"tour_test: skipped {s}")
    for p in problems:
        print(f"tour_test: {p}")
    print(f"tour_test: {ran} commands run, {len(skipped)} skipped, {len(problems)} problem(s)")
    return 1 if problems or ran == 0 else 0


if __name__ == "__main__":
    sys.exit(main())
