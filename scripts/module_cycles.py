#!/usr/bin/env python3
"""Lists import circles between the modules of each crate: modules that, through `use`
declarations and paths written in code (`crate::`, `super::`, `self::`), import each other
in a loop. A module is a source file (inline modules such as `mod tests` belong to their
file); the crate root is left out, and a name the root re-exports counts as an import of the
module that defines it.

    python3 scripts/module_cycles.py [CRATE_DIR ...]    # default: every crate of the workspace

Exits 1 when a crate has a circle (each printed as its modules), 0 otherwise.
"""
import os
import re
import sys

CRATES = ["core", "codegen", "host", "hw-adapter", "tests", "python"]

COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)
STRING = re.compile(r'"(?:\\.|[^"\\])*"')
USE = re.compile(r"\buse\s+((?:crate|super|self)\b[^;]*);", re.S)
PATH = re.compile(r"\b((?:crate|super|self)(?:::[A-Za-z_][A-Za-z0-9_]*)+)")


def modules(src):
    """Module path (tuple) -> file, for every file under `src`."""
    found = {}
    for dirpath, _, files in os.walk(src):
        for f in files:
            if not f.endswith(".rs"):
                continue
            rel = os.path.relpath(os.path.join(dirpath, f), src)[:-3].split(os.sep)
            if rel[-1] == "mod":
                rel = rel[:-1]
            if rel in (["lib"], ["main"]):
                rel = []
            if rel and rel[0] == "bin":
                continue
            found[tuple(rel)] = os.path.join(dirpath, f)
    return found


def expand(tree):
    """`a::{b, c::{d, e}}` -> ["a::b", "a::c::d", "a::c::e"]."""
    tree = re.sub(r"\s+", "", tree)
    i = tree.find("{")
    if i < 0:
        return [tree.split(" as ")[0]]
    prefix, inner = tree[:i], tree[i + 1 : tree.rfind("}")]
    parts, depth, cur = [], 0, ""
    for ch in inner:
        if ch == "," and depth == 0:
            parts.append(cur)
            cur = ""
            continue
        depth += ch == "{"
        depth -= ch == "}"
        cur += ch
    parts.append(cur)
    out = []
    for p in filter(None, parts):
        out += [prefix + x for x in expand(p)]
    return out


def resolve(path, here, mods, reexports):
    """The module a `crate::`/`super::`/`self::` path lands in, or None."""
    segs = [s for s in path.split("::") if s]
    if segs[0] == "crate":
        base, segs = [], segs[1:]
    else:
        base = list(here)
        while segs and segs[0] in ("super", "self"):
            if segs.pop(0) == "super":
                base = base[:-1]
    full = base + segs
    for n in range(len(full), 0, -1):
        if tuple(full[:n]) in mods:
            if n == len(full) or n < len(full):
                return tuple(full[:n])
    # A name defined or re-exported by the root.
    if segs and not base and segs[0] in reexports:
        return reexports[segs[0]]
    return None


def graph(src):
    mods = modules(src)
    texts = {}
    for m, f in mods.items():
        with open(f) as fh:
            texts[m] = STRING.sub('""', COMMENT.sub("", fh.read()))
    reexports = {}
    root = texts.get(())
    if root is not None:
        for u in USE.findall(root) + re.findall(r"\bpub\s+use\s+([a-z_][^;]*);", root):
            for p in expand(u):
                segs = [s for s in p.split("::") if s not in ("crate", "self")]
                target = None
                for n in range(len(segs), 0, -1):
                    if tuple(segs[:n]) in mods:
                        target = tuple(segs[:n])
                        break
                if target:
                    reexports[segs[-1]] = target
    edges = {m: set() for m in mods if m}
    for m, text in texts.items():
        if not m:
            continue
        refs = []
        for u in USE.findall(text):
            refs += expand(u)
        refs += PATH.findall(USE.sub("", text))
        for r in refs:
            t = resolve(r, m, mods, reexports)
            if t and t != m and t != ():
                edges[m].add(t)
    return edges


def circles(edges):
    """Strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in edges:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def main():
    top = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    crates = sys.argv[1:] or [os.path.join(top, c) for c in CRATES]
    found = 0
    for c in crates:
        src = os.path.join(c, "src")
        if not os.path.isdir(src):
            continue
        for comp in circles(graph(src)):
            found += 1
            print(f"{os.path.basename(c.rstrip('/'))}: " + " / ".join("::".join(m) for m in comp))
    print(f"{found} import circle(s)")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
