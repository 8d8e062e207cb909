#!/usr/bin/env python3
"""Checks the Markdown of the repository: every relative link and image in a tracked .md file
points at a file that exists (and at a heading of it, for `file.md#anchor`), README.md and
docs/ cite no issue numbers, and the index docs/README.md links every other page of docs/.
Prints each problem as `file:line: what` and exits 1 if any.

    python3 scripts/check_docs.py
"""

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
LINK = re.compile(r"!?\[(?:[^\]\[]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
ISSUE = re.compile(r"\bissues?\s*#?\d+", re.IGNORECASE)
FENCE = re.compile(r"^\s*(```|~~~)")


def prose_lines(text):
    """(line number, line) outside fenced code blocks, inline code spans blanked."""
    fenced = False
    for n, line in enumerate(text.splitlines(), 1):
        if FENCE.match(line):
            fenced = not fenced
            continue
        if not fenced:
            yield n, re.sub(r"`[^`]*`", "``", line)


def slug(heading):
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower().replace("`", ""))
    return text.replace(" ", "-")


def anchors(path, cache={}):
    if path not in cache:
        seen, found = {}, set()
        fenced = False
        for line in path.read_text(encoding="utf-8").splitlines():
            if FENCE.match(line):
                fenced = not fenced
            elif not fenced and (m := re.match(r"^#{1,6}\s+(.*?)\s*#*\s*$", line)):
                s = slug(m.group(1))
                k = seen.get(s, 0)
                seen[s] = k + 1
                found.add(s if k == 0 else f"{s}-{k}")
        cache[path] = found
    return cache[path]


def check_links(md, problems):
    for n, line in prose_lines(md.read_text(encoding="utf-8")):
        for target in LINK.findall(line):
            if re.match(r"^[a-z][a-z0-9+.-]*:", target, re.IGNORECASE):
                continue  # http:, https:, mailto:
            path, _, anchor = target.partition("#")
            dest = (md.parent / path).resolve() if path else md
            where = f"{md.relative_to(ROOT)}:{n}"
            if not dest.exists():
                problems.append(f"{where}: link to {target}: no such file")
            elif anchor and dest.suffix == ".md" and anchor.lower() not in anchors(dest):
                problems.append(f"{where}: link to {target}: no heading with that anchor")


def check_issue_numbers(md, problems):
    for n, line in prose_lines(md.read_text(encoding="utf-8")):
        for m in ISSUE.finditer(line):
            problems.append(f"{md.relative_to(ROOT)}:{n}: cites {m.group(0)!r}")


def check_index(files, problems):
    index = ROOT / "docs" / "README.md"
    if not index.exists():
        problems.append("docs/README.md: missing (the index of docs/)")
        return
    linked = set()
    for _, line in prose_lines(index.read_text(encoding="utf-8")):
        for target in LINK.findall(line):
            linked.add((index.parent / target.partition("#")[0]).resolve())
    for f in files:
        page = (ROOT / f).resolve()
        if f.startswith("docs/") and page != index and page not in linked:
            problems.append(f"docs/README.md: does not link {f} (one line per page)")


def main():
    try:
        files = subprocess.run(["git", "ls-files", "*.md"], cwd=ROOT, check=True,
                               capture_output=True, text=True).stdout.split()
    except (OSError, subprocess.CalledProcessError):  # not a git checkout
        skip = {"target", ".venv", "node_modules", ".git"}
        files = [str(p.relative_to(ROOT)) for p in ROOT.rglob("*.md")
                 if not skip.intersection(p.relative_to(ROOT).parts)]
    problems = []
    for f in files:
        md = ROOT / f
        if not md.exists():
            continue  # deleted in the work tree
        check_links(md, problems)
        if f == "README.md" or f.startswith("docs/"):
            check_issue_numbers(md, problems)
    check_index(files, problems)
    for p in problems:
        print(p)
    print(f"check_docs: {len(files)} Markdown files, {len(problems)} problems")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
