#!/usr/bin/env python3
"""Lists the functions longer than 100 lines (from the `fn` line to its closing brace) in the
non-test Rust code of the workspace: every crate's `src/`, `examples/` and `build.rs`, with
comments, strings and character literals blanked before the braces are counted. Test code is
left out: a module declared under `#[cfg(test)]` (inline or its own file), a `#[test]`
function, the crates' `tests/` and `benches/`; so is generated code (a file that says
`@generated`, or written to OUT_DIR, which is not in the tree).

    python3 scripts/long_functions.py [--max N] [--report-only PATH ...] [PATH ...]

PATHs (files or folders) default to the workspace's crates. A long function under a
`--report-only` path is listed but does not fail the check (code another change is moving).
Exits 1 when a long function is left outside those paths, 0 otherwise.
"""
import argparse
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CRATES = ["core", "codegen", "host", "hw-adapter", "hw-adapter/mock-arms", "tests", "python"]
MAX_LINES = 100

FN = re.compile(r"\bfn\s+([A-Za-z_]\w*)")
CFG_TEST_MOD = re.compile(r"#\[cfg\((?:[^()]|\([^()]*\))*\btest\b(?:[^()]|\([^()]*\))*\)\]\s*"
                          r"(?:#\[[^\]]*\]\s*)*(?:pub(?:\([^)]*\))?\s+)?mod\s+([A-Za-z_]\w*)\s*([;{])")
TEST_FN = re.compile(r"#\[(?:\w+::)*test\b[^\]]*\]\s*(?:#\[[^\]]*\]\s*)*")


def blank(text):
    """`text` with comments, strings and character literals replaced by spaces (newlines
    kept, so line numbers stay)."""
    out, i, n = [], 0, len(text)

    def spaces(s):
        return re.sub(r"[^\n]", " ", s)

    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(spaces(text[i:j]))
            i = j
        elif text.startswith("/*", i):
            depth, j = 1, i + 2
            while j < n and depth:
                if text.startswith("/*", j):
                    depth, j = depth + 1, j + 2
                elif text.startswith("*/", j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
            out.append(spaces(text[i:j]))
            i = j
        elif (m := re.compile(r'b?r(#*)"').match(text, i)) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            close = '"' + m.group(1)
            j = text.find(close, m.end())
            j = n if j < 0 else j + len(close)
            out.append(spaces(text[i:j]))
            i = j
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append(spaces(text[i:j + 1]))
            i = j + 1
        elif c == "'" and (m := re.compile(r"'(?:\\u\{[0-9a-fA-F]+\}|\\x[0-9a-fA-F]{2}|\\.|[^\\'\n])'").match(text, i)):
            out.append(spaces(m.group(0)))
            i = m.end()
        else:
            out.append(c)
            i += 1
    return "".join(out)


def matching(text, open_at):
    """Index of the brace that closes the one at `open_at`."""
    depth = 0
    for j in range(open_at, len(text)):
        if text[j] == "{":
            depth += 1
        elif text[j] == "}":
            depth -= 1
            if depth == 0:
                return j
    return len(text) - 1


def test_spans(code):
    """(start, end) of the test code written in a file: `#[cfg(test)]` inline modules and
    `#[test]` functions; and the names of the test modules it declares in files of their own."""
    spans, outlined = [], set()
    for m in CFG_TEST_MOD.finditer(code):
        if m.group(2) == "{":
            spans.append((m.start(), matching(code, m.end() - 1)))
        else:
            outlined.add(m.group(1))
    for m in TEST_FN.finditer(code):
        f = FN.match(code, code.find("fn", m.end()))
        if f:
            body = code.find("{", f.end())
            spans.append((m.start(), matching(code, body)))
    return spans, outlined


def long_functions(path, code, max_lines):
    """(line, name, lines) of every function over `max_lines` lines outside test code."""
    spans, _ = test_spans(code)
    found = []
    for m in FN.finditer(code):
        if any(a <= m.start() <= b for a, b in spans):
            continue
        # The body: the first `{` after the signature, unless a `;` ends it first (a
        # declaration without a body). Braces of const generic arguments are rare enough in
        # signatures to ignore.
        semi, brace = code.find(";", m.end()), code.find("{", m.end())
        if brace < 0 or 0 <= semi < brace:
            continue
        end = matching(code, brace)
        first = code.count("\n", 0, m.start()) + 1
        last = code.count("\n", 0, end) + 1
        if last - first + 1 > max_lines:
            found.append((first, m.group(1), last - first + 1))
    return found


def test_files(paths):
    """Files that are test modules declared by `#[cfg(test)] mod name;` in their parent."""
    out = set()
    for f in paths:
        with open(f, encoding="utf-8") as fh:
            _, outlined = test_spans(blank(fh.read()))
        d, base = os.path.dirname(f), os.path.basename(f)[:-3]
        here = d if base in ("mod", "lib", "main") else os.path.join(d, base)
        for name in outlined:
            out.add(os.path.join(here, name + ".rs"))
            out.add(os.path.join(here, name, "mod.rs"))
    return out


def sources(targets):
    """The non-test Rust files under `targets` (files or folders)."""
    files = []
    for t in targets:
        if os.path.isfile(t):
            files.append(t)
            continue
        for dirpath, dirs, names in os.walk(t):
            rel = os.path.relpath(dirpath, t).split(os.sep)
            dirs[:] = [d for d in dirs if d not in ("target", "tests", "benches", ".git", "node_modules")]
            if rel == ["."]:
                dirs[:] = [d for d in dirs if d in ("src", "examples")]
            files += [os.path.join(dirpath, n) for n in names if n.endswith(".rs")
                      and (rel != ["."] or n == "build.rs")]
    tests = test_files(files)
    return sorted(f for f in files if f not in tests)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--max", type=int, default=MAX_LINES, help="longest a function may be, in lines")
    ap.add_argument("--report-only", nargs="*", default=[], metavar="PATH",
                    help="files or folders whose long functions are listed without failing")
    ap.add_argument("paths", nargs="*", help="files or folders (default: the workspace's crates)")
    args = ap.parse_args(argv)
    targets = args.paths or [os.path.join(ROOT, c) for c in CRATES]
    lenient = [os.path.abspath(p) for p in args.report_only]
    failing = reported = 0
    for f in sources(targets):
        with open(f, encoding="utf-8") as fh:
            text = fh.read()
        if "@generated" in text[:2000]:
            continue
        for line, name, n in long_functions(f, blank(text), args.max):
            full = os.path.abspath(f)
            only_report = any(full == p or full.startswith(p.rstrip(os.sep) + os.sep) for p in lenient)
            shown = os.path.relpath(f, ROOT) if full.startswith(ROOT + os.sep) else f
            print(f"{shown}:{line}: fn {name}: {n} lines{' (reported only)' if only_report else ''}")
            reported += only_report
            failing += not only_report
    print(f"long_functions: {failing + reported} function(s) over {args.max} lines"
          + (f", {reported} of them reported only" if reported else ""))
    return 1 if failing else 0


if __name__ == "__main__":
    sys.exit(main())
