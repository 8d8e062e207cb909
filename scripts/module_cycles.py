#!/usr/bin/env python3
"""Lists import circles between the modules of each crate: modules that import each other in
a loop, through `use` declarations and paths written in code (`crate::`, `super::`, `self::`,
or a child module's name, as in `use composite::Composite;` or `rrt::connect(..)`).

A module is a source file (inline modules such as `mod tests` belong to their file). A parent
that uses its child while the child uses the parent is a circle too. A `pub use` that
re-exports an item is not an import of its own (so a facade `mod.rs` or the crate root that
only re-exports makes no circle); a path through a re-export imports both the module that
defines the item and the module whose re-export it goes through (`crate::collision::X`, where
collision re-exports model's X, imports model and collision: a module that reaches its own item
that way imports the re-exporting module, which is a circle when that module imports it back).
Each circle is printed with, per import inside it, the first path that makes it.

    python3 scripts/module_cycles.py [CRATE_DIR ...]    # default: every crate of the workspace

Exits 1 when a crate has a circle (each printed as its modules), 0 otherwise.
"""
import os
import re
import sys

CRATES = ["core", "codegen", "host", "hw-adapter", "hw-adapter/mock-arms", "tests", "python"]

COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)
STRING = re.compile(r'"(?:\\.|[^"\\])*"')
USE = re.compile(r"\b(pub(?:\([^)]*\))?\s+)?use\s+([^;]*);", re.S)
PATH = re.compile(r"(?<![:\w])([a-z_][a-z0-9_]*(?:::[A-Za-z_][A-Za-z0-9_]*)+)")


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


def inline_modules(text):
    """(name, start, end) of every `mod name { .. }` written inline in a file."""
    found = []
    for m in re.finditer(r"\bmod\s+([A-Za-z_]\w*)\s*\{", text):
        depth, i = 0, m.end() - 1
        while i < len(text):
            depth += text[i] == "{"
            depth -= text[i] == "}"
            if depth == 0:
                break
            i += 1
        found.append((m.group(1), m.end(), i))
    return found


def enclosing(inline, pos):
    """Names of the inline modules around `pos`, outermost first."""
    return [name for name, start, end in inline if start <= pos < end]


def expand(tree):
    """`a::{b, c::{d, e}}` -> ["a::b", "a::c::d", "a::c::e"]."""
    tree = re.sub(r"\s+", " ", tree).strip()
    i = tree.find("{")
    if i < 0:
        return [tree.split(" as ")[0].replace(" ", "")]
    prefix, inner = tree[:i].replace(" ", ""), tree[i + 1 : tree.rfind("}")]
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
    for p in filter(str.strip, parts):
        out += [prefix + x for x in expand(p)]
    return out


class Crate:
    def __init__(self, src):
        self.mods = modules(src)
        self.uses = {}  # module -> [path] (imports)
        self.pub_uses = {}  # module -> [path] (re-exports)
        for m, f in self.mods.items():
            with open(f) as fh:
                text = STRING.sub('""', COMMENT.sub("", fh.read()))
            inline = inline_modules(text)
            # (path, the inline modules it is written in), for imports and re-exports.
            uses, pub_uses = [], []
            for u in USE.finditer(text):
                within = enclosing(inline, u.start())
                for path in expand(u.group(2)):
                    (pub_uses if u.group(1) else uses).append((path, within))
            blanked = USE.sub(lambda u: " " * len(u.group(0)), text)
            for p in PATH.finditer(blanked):
                uses.append((p.group(1), enclosing(inline, p.start())))
            self.uses[m] = uses
            self.pub_uses[m] = [path for path, within in pub_uses if not within]

    def children(self, m):
        return {c[-1] for c in self.mods if len(c) == len(m) + 1 and c[: len(m)] == m}

    def absolute(self, path, here):
        """Segments of a path written in module `here`, from the crate root; None when the
        path starts outside the crate (std, another crate)."""
        segs = [s for s in path.split("::") if s]
        if not segs:
            return None
        if segs[0] == "crate":
            return segs[1:]
        if segs[0] in ("super", "self"):
            base = list(here)
            while segs and segs[0] in ("super", "self"):
                if segs.pop(0) == "super":
                    base = base[:-1]
            return base + segs
        if segs[0] in self.children(here):
            return list(here) + segs
        return None

    def resolve(self, segs, seen=()):
        """(the module that defines what an absolute path names, the modules whose `pub use`
        the path reaches it through); (None, ()) for a path that names no module."""
        for n in range(len(segs), -1, -1):
            prefix = tuple(segs[:n])
            if prefix not in self.mods:
                continue
            rest = segs[n:]
            if rest and (prefix, rest[0]) not in seen:
                # A name the module re-exports: the module it comes from.
                for p in self.pub_uses.get(prefix, ()):
                    if p.split("::")[-1] == rest[0] or p.endswith("::*"):
                        target = self.absolute(p, prefix)
                        if target is None:
                            continue
                        if p.endswith("::*"):
                            target = target[:-1] + [rest[0]]
                        got, via = self.resolve(target + rest[1:], seen + ((prefix, rest[0]),))
                        if got is not None and got != prefix:
                            return got, (prefix,) + via
            return prefix, ()
        return None, ()

    def graph(self):
        """Module -> the modules it imports: for every path it writes, the module that defines
        the item and every module whose re-export the path goes through (the path breaks when
        that re-export goes). An item a module reaches through a re-export elsewhere is its own
        (no edge to itself), but the re-exporting module is still imported."""
        edges = {m: set() for m in self.mods if m}
        self.why = {}  # (module, imported module) -> the first path written for it
        for m in edges:
            for path, within in self.uses[m]:
                here = tuple(m) + tuple(within)
                segs = self.absolute(path, here)
                if segs is None:
                    continue
                if tuple(segs[: len(here)]) == here and within:
                    continue  # inside the file's own inline modules
                t, via = self.resolve(segs)
                for d in (t,) + via:
                    if d and d != m:
                        edges[m].add(d)
                        self.why.setdefault((m, d), path)
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
        crate = Crate(src)
        edges = crate.graph()
        for comp in circles(edges):
            found += 1
            print(f"{os.path.basename(c.rstrip('/'))}: " + " / ".join("::".join(m) for m in comp))
            for m in comp:
                for d in sorted(edges[m] & set(comp)):
                    print(f"    {'::'.join(m)} -> {'::'.join(d)}: {crate.why[(m, d)]}")
    print(f"{found} import circle(s)")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
