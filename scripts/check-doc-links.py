#!/usr/bin/env python3
"""Checks that every relative link of the given Markdown pages leads
somewhere: the file exists and, for a link into a Markdown page, the anchor
is one of its headings (GitHub's slugs). Prints each broken link with its
page and line; exits 1 if there is one.

    scripts/check-doc-links.py README.md docs/*.md
"""
import re
import sys
from pathlib import Path

LINK = re.compile(r"\]\(([^)\s]+)\)")


def lines_outside_code(text):
    """(line number, line) of the lines outside fenced code blocks."""
    fenced = False
    for number, line in enumerate(text.splitlines(), 1):
        if line.startswith("```"):
            fenced = not fenced
            continue
        if not fenced:
            yield number, line


def slug(heading):
    """GitHub's anchor of a heading: lower case, punctuation dropped,
    spaces as hyphens."""
    text = heading.strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path):
    """Every anchor of a Markdown page, repeated headings numbered."""
    seen = {}
    for _, line in lines_outside_code(path.read_text(encoding="utf-8")):
        m = re.match(r"#{1,6} (.*)", line)
        if m:
            base = slug(m.group(1))
            n = seen.get(base, 0)
            seen[base] = n + 1
            yield base if n == 0 else f"{base}-{n}"


def broken_links(page):
    text = page.read_text(encoding="utf-8")
    for number, line in lines_outside_code(text):
        line = re.sub(r"`[^`]*`", "", line)
        for target in LINK.findall(line):
            if re.match(r"[a-z]+:", target):
                continue
            path, _, anchor = target.partition("#")
            dest = (page.parent / path).resolve() if path else page.resolve()
            if not dest.exists():
                yield number, target, "no such file"
            elif anchor and dest.suffix == ".md" and anchor not in set(anchors(dest)):
                yield number, target, f"no heading '{anchor}' in {path or page.name}"


def main(pages):
    bad = 0
    for name in pages:
        page = Path(name)
        for number, target, why in broken_links(page):
            print(f"{name}:{number}: broken link ({target}): {why}")
            bad += 1
    if bad:
        sys.exit(1)
    print(f"check-doc-links: every link of {len(pages)} pages leads somewhere")


if __name__ == "__main__":
    main(sys.argv[1:])
