#!/usr/bin/env python3
"""Fails on a broken relative link in the book (docs/src/**/*.md), the
results pages (docs/results/**/*.md), models/, fixtures/ and README.md: a link to a
file that does not exist, or to an anchor that no heading of the target
page produces (mdBook's heading ids).

    python3 scripts/check-book-links.py
"""

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LINK = re.compile(r"!?\[(?:[^\]\[]|\[[^\]]*\])*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")


def prose(text: str) -> str:
    """The text without fenced code blocks and inline code."""
    text = re.sub(r"(?ms)^(```|~~~).*?^\1[^\n]*$", "", text)
    return re.sub(r"`[^`\n]*`", "", text)


def slug(heading: str) -> str:
    """mdBook's id of a heading: lowercased, punctuation but `-` and `_`
    dropped, spaces to `-`."""
    heading = re.sub(r"`([^`]*)`", r"\1", heading)
    heading = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading)
    out = []
    for c in heading.strip().lower():
        if c.isalnum() or c in "-_":
            out.append(c)
        elif c.isspace():
            out.append("-")
    return "".join(out)


def anchors(page: Path) -> set:
    ids, seen = set(), {}
    for line in prose(page.read_text()).splitlines():
        m = re.match(r"#{1,6}\s+(.*?)\s*#*\s*$", line)
        if m:
            base = slug(m.group(1))
            n = seen.get(base, 0)
            seen[base] = n + 1
            ids.add(base if n == 0 else f"{base}-{n}")
    return ids


def main() -> int:
    pages = [
        *sorted((ROOT / "docs" / "src").rglob("*.md")),
        *sorted((ROOT / "docs" / "results").rglob("*.md")),
        *sorted((ROOT / "models").rglob("*.md")),
        *sorted((ROOT / "fixtures").rglob("*.md")),
        ROOT / "README.md",
    ]
    errors = []
    for page in pages:
        for m in LINK.finditer(prose(page.read_text())):
            target = m.group(1)
            if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # http:, mailto:, …
                continue
            path, _, anchor = target.partition("#")
            dest = (page.parent / path).resolve() if path else page
            rel = page.relative_to(ROOT)
            if not dest.exists():
                errors.append(f"{rel}: link to missing file {target}")
            elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
                errors.append(f"{rel}: link to missing anchor {target}")
    for e in errors:
        print(e, file=sys.stderr)
    print(f"{len(pages)} pages checked, {len(errors)} broken links", file=sys.stderr)
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
