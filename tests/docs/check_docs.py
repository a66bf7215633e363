#!/usr/bin/python3
"""Keeps docs/ true to the binary: every long flag `solid CMD --help` prints must appear in
that command's page, a page's flag table may name only flags --help prints, and every
relative link in README.md and docs/*.md must resolve. Commands are discovered from the
help output so a new subcommand cannot go undocumented silently."""

import argparse
import os
import re
import subprocess
import sys

# Whole words only: "--no-decodeX" must not count as "--no-decode".
FLAG = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]*(?![\w-])")
# A table row whose first cell is a flag, e.g. "| `--seed N` | ...".
TABLE_FLAG = re.compile(r"^\|\s*`?(--[a-z][a-z0-9-]*)(?![\w-])")
LINK = re.compile(r"\]\(([^)\s]+)\)")


def run_help(solid, words):
    out = subprocess.run([solid, *words, "--help"], stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True, timeout=60)
    return out.stdout


def subcommands(text):
    """Names listed under CLI11's 'Subcommands:' heading."""
    names, inside = [], False
    for line in text.splitlines():
        if line.startswith("Subcommands:"):
            inside = True
            continue
        if inside:
            m = re.match(r"^  ([a-z][a-z0-9-]*)\s", line)
            if m:
                names.append(m.group(1))
            elif line.strip() and not line.startswith(" "):
                inside = False
    return names


def commands(solid):
    """(words, help text) of every leaf command, e.g. (['convert', 'gltf'], ...)."""
    leaves = []
    for name in subcommands(run_help(solid, [])):
        text = run_help(solid, [name])
        subs = subcommands(text)
        if subs:
            leaves.extend(([name, s], run_help(solid, [name, s])) for s in subs)
        else:
            leaves.append(([name], text))
    return leaves


def help_flags(text):
    # --help and --version belong to every command and say nothing about it.
    return sorted(set(FLAG.findall(text)) - {"--help", "--version"})


def table_flags(text):
    return {m.group(1) for line in text.splitlines() if (m := TABLE_FLAG.match(line))}


def check_links(root, files):
    problems = []
    for path in files:
        with open(path, encoding="utf-8") as f:
            text = f.read()
        # Code blocks hold shell and Python, not links.
        text = re.sub(r"(?s)```.*?```", "", text)
        for target in LINK.findall(text):
            if re.match(r"^[a-z]+:", target) or target.startswith("#"):
                continue
            file_part = target.split("#")[0]
            resolved = os.path.normpath(os.path.join(os.path.dirname(path), file_part))
            if not os.path.exists(resolved):
                problems.append(f"{os.path.relpath(path, root)}: link to {target}: no such file")
    return problems


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--solid", required=True)
    ap.add_argument("--docs", required=True)
    args = ap.parse_args()
    docs = os.path.abspath(args.docs)
    root = os.path.dirname(docs)
    problems = []
    # convert and export have one page for their subcommands, so a page's table may name a
    # flag of any of them: group the leaves by page.
    by_page = {}
    for words, text in commands(args.solid):
        by_page.setdefault(words[0], []).append((" ".join(words), help_flags(text)))
    for page_name, leaves in sorted(by_page.items()):
        page = os.path.join(docs, page_name + ".md")
        if not os.path.exists(page):
            problems.append(f"solid {page_name}: no page {os.path.relpath(page, root)}")
            continue
        with open(page, encoding="utf-8") as f:
            text = f.read()
        documented = set(FLAG.findall(text))
        known = set()
        for name, flags in leaves:
            known.update(flags)
            for flag in flags:
                if flag not in documented:
                    problems.append(f"solid {name}: {flag} is in --help but not in {os.path.basename(page)}")
        for flag in sorted(table_flags(text) - known):
            problems.append(f"solid {page_name}: {os.path.basename(page)} has a table row for {flag}, "
                            "which no --help of the command prints")
    md = [os.path.join(root, "README.md")] + sorted(
        os.path.join(docs, n) for n in os.listdir(docs) if n.endswith(".md"))
    problems += check_links(root, [p for p in md if os.path.exists(p)])
    for p in problems:
        print(p, file=sys.stderr)
    print(f"check_docs: {len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
