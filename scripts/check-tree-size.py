#!/usr/bin/env python3
"""Keep the tracked tree small enough to clone, read and ship.

Limits (a clone stays light, and the working tree travels to a borrowed
GPU machine, which carries at most 64 MiB):

- at most 2,500 tracked files and 40 MiB in all (sizes of `git ls-files`);
- no tracked file over 2 MiB outside `models/`;
- `models/` (the pretrained policies) at most 10 MiB.

Checkpoints, per-episode CSVs of intermediate runs and study state stay
out of git: `scripts/keep-study.sh` keeps a study's report only.

Usage: python3 scripts/check-tree-size.py   (exit 1 and the reasons when a
limit is broken)
"""

import os
import subprocess
import sys

MIB = 1024 * 1024
MAX_FILES = 2500
MAX_TOTAL = 40 * MIB
MAX_FILE = 2 * MIB
MAX_MODELS = 10 * MIB


def tracked(root):
    out = subprocess.run(
        ["git", "ls-files", "-z"], cwd=root, check=True, capture_output=True
    ).stdout
    return [p for p in out.decode().split("\0") if p]


def main():
    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
    sizes = {}
    for path in tracked(root):
        full = os.path.join(root, path)
        # A file deleted in the working tree but still in the index counts 0.
        sizes[path] = os.path.getsize(full) if os.path.isfile(full) else 0
    total = sum(sizes.values())
    models = sum(s for p, s in sizes.items() if p.startswith("models/"))
    problems = []
    if len(sizes) > MAX_FILES:
        problems.append(f"{len(sizes)} tracked files (at most {MAX_FILES})")
    if total > MAX_TOTAL:
        problems.append(f"tracked tree {total / MIB:.1f} MiB (at most {MAX_TOTAL // MIB} MiB)")
    if models > MAX_MODELS:
        problems.append(f"models/ {models / MIB:.1f} MiB (at most {MAX_MODELS // MIB} MiB)")
    for path, size in sorted(sizes.items()):
        if size > MAX_FILE and not path.startswith("models/"):
            problems.append(f"{path}: {size / MIB:.2f} MiB (at most {MAX_FILE // MIB} MiB outside models/)")
    print(
        f"tracked tree: {len(sizes)} files, {total / MIB:.1f} MiB; models/ {models / MIB:.2f} MiB"
    )
    for p in problems:
        print(f"error: {p}", file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
