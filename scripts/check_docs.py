#!/usr/bin/env python3
"""Checks the Markdown of the repository: every relative link and image in a tracked .md file
points at a file that exists (and at a heading of it, for `file.md#anchor`), README.md and
docs/ cite no issue numbers, the index docs/README.md links every other page of docs/, and
the tree of docs/ARCHITECTURE.md (its first code block) covers the code: every source file of
every crate and every subcommand of `omcbsa`. Prints each problem as `file:line: what` and
exits 1 if any.

The tree covers a file `<crate>/src/<path>.rs` when an entry under `<crate>/` names it
(`  src/model.rs`, or in a list `  src/spline.rs, stream.rs`, the later names in the first's
folder) or names a folder it is in (`  src/suite/` covers `src/suite/*.rs` and below); the
crate root (`src/lib.rs`, `src/main.rs`, `src/bin/*.rs`) is covered by the crate's own entry.
An entry that names a file or folder that is not there is a problem too. The subcommands come
from the `#[derive(Subcommand)]` enum of host/src/main.rs (clap's names: a variant in kebab
case, or its `#[command(name = ..)]`); the tree must list each in host's `CLI (..)`.

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
COMMENT_RS = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)


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


CRATES = ["core", "codegen", "host", "hw-adapter", "hw-adapter/mock-arms", "python"]
ARCHITECTURE = "docs/ARCHITECTURE.md"
CLI_MAIN = "host/src/main.rs"


def tree_block(text):
    """(first line number, lines) of the first fenced code block."""
    lines, start = [], None
    for n, line in enumerate(text.splitlines(), 1):
        if FENCE.match(line):
            if start is not None:
                break
            start = n + 1
        elif start is not None:
            lines.append(line)
    return start or 1, lines


def tree_entries(lines, first):
    """(line number, crate folder or None, [path]) for each entry of the tree: a line whose
    name column (what comes before two spaces) starts within the first 4 columns. A top-level
    folder (`host/`) is the crate of the entries indented under it; an entry's later names
    (`src/spline.rs, stream.rs`) are in its first name's folder."""
    entries, crate = [], None
    for n, line in enumerate(lines, first):
        indent = len(line) - len(line.lstrip())
        if not line.strip() or indent >= 4 or line.lstrip()[0] in "|v":
            continue
        names = [x.strip() for x in re.split(r"\s{2,}", line.strip())[0].split(",")]
        if not names or " " in names[0]:
            continue
        if indent == 0:
            crate = names[0].rstrip("/") if names[0].endswith("/") else None
            entries.append((n, None, names))
            continue
        folder = names[0].rstrip("/").rpartition("/")[0]
        paths = [names[0]] + [f"{folder}/{x}" if folder else x for x in names[1:]]
        entries.append((n, crate, paths))
    return entries


def check_architecture(problems):
    doc = ROOT / ARCHITECTURE
    first, lines = tree_block(doc.read_text(encoding="utf-8"))
    entries = tree_entries(lines, first)
    tops = {paths[0].rstrip("/") for _, crate, paths in entries if crate is None}
    files, folders = set(), set()
    for n, crate, paths in entries:
        if crate not in CRATES:
            continue
        for p in paths:
            full = f"{crate}/{p.rstrip('/')}"
            if p.startswith("src/") and not (ROOT / full).exists():
                problems.append(f"{ARCHITECTURE}:{n}: the tree names {full}{'/' if p.endswith('/') else ''}, "
                                "which is not there (moved or removed? fix the entry)")
            (folders if p.endswith("/") else files).add(full)
    for crate in CRATES:
        for f in sorted((ROOT / crate / "src").rglob("*.rs")):
            rel = f.relative_to(ROOT).as_posix()
            inside = rel[len(crate) + len("/src/"):]
            if inside in ("lib.rs", "main.rs") or inside.startswith("bin/"):
                if crate not in tops:
                    problems.append(f"{ARCHITECTURE}: the tree has no entry `{crate}/` (for {rel})")
                continue
            if rel in files or any(rel.startswith(d + "/") for d in folders):
                continue
            problems.append(f"{ARCHITECTURE}: {rel} is in no entry of the tree (add `  src/{inside}` "
                            f"under `{crate}/`, or its folder, with what it holds)")
    check_commands(lines, first, problems)


def subcommands():
    """The `omcbsa` subcommands as clap names them, from host/src/main.rs."""
    text = COMMENT_RS.sub("", (ROOT / CLI_MAIN).read_text(encoding="utf-8"))
    m = re.search(r"#\[derive\([^)]*\bSubcommand\b[^)]*\)\]\s*(?:#\[[^\]]*\]\s*)*"
                  r"(?:pub(?:\([^)]*\))?\s+)?enum\s+\w+\s*\{", text)
    if not m:
        return None
    depth, i = 1, m.end()
    while depth and i < len(text):
        depth += {"{": 1, "}": -1}.get(text[i], 0)
        i += 1
    body, names = text[m.end():i - 1], []
    for v in re.finditer(r"((?:#\[[^\]]*\]\s*)*)([A-Z]\w*)\s*[({,]", body):
        if re.search(r"\{[^{}]*$", body[:v.start()]):
            continue  # a field of a struct variant
        named = re.search(r'#\[command\([^\]]*\bname\s*=\s*"([^"]+)"', v.group(1))
        names.append(named.group(1) if named else re.sub(r"(?<!^)([A-Z])", r"-\1", v.group(2)).lower())
    return names


def check_commands(lines, first, problems):
    commands = subcommands()
    if not commands:
        problems.append(f"{CLI_MAIN}: no `#[derive(Subcommand)]` enum found (the subcommands to check)")
        return
    block = "\n".join(lines)
    m = re.search(r"CLI \(([^)]*)\)", block)
    if not m:
        problems.append(f"{ARCHITECTURE}: the tree has no `CLI (..)` list of the subcommands under host/")
        return
    n = first + block[:m.start()].count("\n")
    listed = [x for x in re.split(r"[,\s]+", m.group(1)) if x]
    for c in commands:
        if c not in listed:
            problems.append(f"{ARCHITECTURE}:{n}: the subcommand `omcbsa {c}` is not in the tree's CLI (..) list")
    for c in listed:
        if c not in commands:
            problems.append(f"{ARCHITECTURE}:{n}: the tree's CLI (..) list names `{c}`, which is no subcommand")


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
    check_architecture(problems)
    for p in problems:
        print(p)
    print(f"check_docs: {len(files)} Markdown files, {len(problems)} problems")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
