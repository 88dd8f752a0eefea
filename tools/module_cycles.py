#!/usr/bin/env python3
"""Import circles between the modules of one Rust crate.

    python3 tools/module_cycles.py core/src          # cycles only; exit 1 if there is one
    python3 tools/module_cycles.py --map host/src    # also what every module file imports

Maps every module file under a crate's `src/` to the top-level and second-level modules it
imports: `use` trees (`use crate::a::{b::X, Y}`, `use super::…`, `use self::…`, a child module's
name), and paths in code (`crate::a::b::f()`, `super::x::Y`, `child::f()`). Comments, strings
and character literals are ignored, so doc links are not imports; `pub(super)`/`pub(in …)` are
visibilities, not imports. An inline `mod name { … }` (a file's `mod tests`) counts as part of the
file's module; `super::` inside it is resolved from the inline module.

Graphs, each checked for cycles (strongly connected components of more than one module):
* the top-level modules (`crate::a` → `crate::b`, every file below `a/` counting as `a`);
* for each top-level module `a`, its second-level modules (`a::x` → `a::y`; deeper files count
  as their second-level ancestor). Edges between a module and its own parent (`a/mod.rs`
  re-exporting `a::x`, `a::x` using an item of `a/mod.rs`) are not sibling edges and are left
  out.

For every cycle, one circle of edges is printed with the file and line that makes each edge.
Python 3 standard library only.
"""

import argparse
import os
import re
import sys

IDENT = r"[A-Za-z_][A-Za-z0-9_]*"


def strip_code(text):
    """`text` with comments, string and char literals blanked (newlines kept for line numbers)."""
    out = []
    i, n = 0, len(text)

    def blank(s):
        return "".join("\n" if c == "\n" else " " for c in s)

    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(blank(text[i:j]))
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
            out.append(blank(text[i:j]))
            i = j
        elif (m := re.compile(r'b?r(#*)"').match(text, i)) and (
            i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")
        ):
            end = '"' + m.group(1)
            j = text.find(end, m.end())
            j = n if j < 0 else j + len(end)
            out.append(blank(text[i:j]))
            i = j
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append(blank(text[i : j + 1]))
            i = j + 1
        elif c == "'":
            m = re.compile(r"'(\\(x[0-9a-fA-F]{2}|u\{[0-9a-fA-F]+\}|.)|[^\\'\n])'").match(text, i)
            if m:
                out.append(blank(m.group(0)))
                i = m.end()
            else:  # a lifetime or a label
                out.append(c)
                i += 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def module_of(src, path):
    """Module path (list of names) of a file under `src`, or None for a crate root."""
    rel = os.path.relpath(path, src).replace(os.sep, "/")
    parts = rel[:-3].split("/")
    if parts[0] == "bin" or rel in ("lib.rs", "main.rs"):
        return None
    if parts[-1] == "mod":
        parts = parts[:-1]
    return parts


def split_use_tree(tree):
    """Flatten a `use` tree (`a::{b::C, d as E}` …) into (segments, name bound) pairs."""
    tree = re.sub(r"\s+as\s+", "@", tree.strip())
    tree = re.sub(r"\s+", "", tree)
    out = []

    def walk(prefix, s):
        # split s at top-level commas
        depth, start, items = 0, 0, []
        for k, ch in enumerate(s):
            if ch == "{":
                depth += 1
            elif ch == "}":
                depth -= 1
            elif ch == "," and depth == 0:
                items.append(s[start:k])
                start = k + 1
        items.append(s[start:])
        for it in items:
            if not it:
                continue
            b = it.find("{")
            if b >= 0 and it.endswith("}"):
                head = [p for p in it[:b].split("::") if p]
                walk(prefix + head, it[b + 1 : -1])
            else:
                path, _, alias = it.partition("@")
                segs = prefix + [p for p in path.split("::") if p]
                name = alias or (segs[-1] if segs else "")
                if name == "self" and len(segs) > 1:
                    segs, name = segs[:-1], segs[-2]
                out.append((segs, name))

    walk([], tree)
    return out


class Crate:
    def __init__(self, src):
        self.src = src
        self.files = {}  # path -> module list
        self.modules = set()  # tuples of every known module path (files and inline mods)
        for root, _, names in os.walk(src):
            for nm in sorted(names):
                if nm.endswith(".rs"):
                    p = os.path.join(root, nm)
                    m = module_of(src, p)
                    self.files[p] = m
                    if m:
                        for k in range(1, len(m) + 1):
                            self.modules.add(tuple(m[:k]))
        self.code = {p: strip_code(open(p, encoding="utf-8").read()) for p in self.files}
        for p, m in self.files.items():
            for inline in self.inline_mods(self.code[p]):
                self.modules.add(tuple((m or []) + inline))
        # `pub use` of each file's module: name -> (module it was written in, segments), and the
        # glob re-exports (`pub use x::*`), followed so that `super::Name` leads to the sibling
        # that defines Name rather than to the parent that re-exports it.
        self.reexports, self.globs = {}, {}
        for p, m in self.files.items():
            here = m or []
            for u in re.finditer(r"\bpub\s+use\s+([^;]*);", self.code[p]):
                for segs, name in split_use_tree(u.group(1)):
                    if name == "*":
                        self.globs.setdefault(tuple(here), []).append(segs[:-1])
                    elif name:
                        self.reexports.setdefault(tuple(here), {})[name] = segs
        self.defs = {}  # module -> names defined at its top level (for globs)
        for p, m in self.files.items():
            names = set(re.findall(r"\b(?:fn|struct|enum|trait|type|const|static|union|mod)\s+(" + IDENT + r")", self.code[p]))
            names |= set(re.findall(r"macro_rules!\s*(" + IDENT + r")", self.code[p]))
            self.defs[tuple(m or [])] = names

    @staticmethod
    def inline_mods(code):
        """Paths (relative to the file's module) of every inline `mod x { … }`."""
        stack, found, depth = [], [], 0
        for tok in re.finditer(r"\bmod\s+(" + IDENT + r")\s*\{|\{|\}", code):
            if tok.group(1):
                depth += 1
                stack.append((tok.group(1), depth))
                found.append([s for s, _ in stack])
            elif tok.group(0) == "{":
                depth += 1
            else:
                if stack and stack[-1][1] == depth:
                    stack.pop()
                depth -= 1
        return found

    def resolve(self, here, segs, hops=0):
        """Absolute module path named by `segs` from module `here` (None if not crate-local),
        following re-exports to the module that defines the item."""
        if not segs:
            return None
        if segs[0] == "crate":
            path, rest = [], segs[1:]
        elif segs[0] in ("super", "self"):
            path, rest = list(here), segs
            while rest and rest[0] in ("super", "self"):
                if rest[0] == "super":
                    if not path:
                        return None
                    path = path[:-1]
                rest = rest[1:]
        elif tuple(here + [segs[0]]) in self.modules:
            path, rest = list(here), segs  # a child module by its bare name
        elif not here and (segs[0],) in self.modules:
            path, rest = [], segs
        else:
            return None
        # the longest prefix that is a module
        k = 0
        while k < len(rest) and tuple(path + [rest[k]]) in self.modules:
            path, k = path + [rest[k]], k + 1
        if k < len(rest) and hops < 8:
            name = rest[k]
            re_ = self.reexports.get(tuple(path), {}).get(name)
            if re_ is not None:
                t = self.resolve(path, re_ + rest[k + 1 :], hops + 1)
                if t is not None:
                    return t
            elif name not in self.defs.get(tuple(path), set()):
                for g in self.globs.get(tuple(path), []):
                    gm = self.resolve(path, g, hops + 1)
                    if gm is not None and name in self.defs.get(tuple(gm), set()):
                        return gm
        return path

    def imports(self, path):
        """(line, source module, target module) for every crate-local path in a file."""
        base = self.files[path] or []
        code = self.code[path]
        code = re.sub(r"\bpub\s*\(\s*(in\s+[^)]*|crate|super|self)\s*\)", lambda m: " " * len(m.group(0)), code)
        # inline module stack per offset
        events = []
        stack, depth = [], 0
        for tok in re.finditer(r"\bmod\s+(" + IDENT + r")\s*\{|\{|\}", code):
            if tok.group(1):
                depth += 1
                stack.append((tok.group(1), depth))
            elif tok.group(0) == "{":
                depth += 1
            else:
                if stack and stack[-1][1] == depth:
                    stack.pop()
                depth -= 1
            events.append((tok.end(), [s for s, _ in stack]))

        def here_at(off):
            cur = []
            for end, st in events:
                if end > off:
                    break
                cur = st
            return base + cur

        def line_of(off):
            return code.count("\n", 0, off) + 1

        out = []
        used = []
        for m in re.finditer(r"\buse\s+([^;]*);", code):
            used.append((m.start(), m.end()))
            here = here_at(m.start())
            for segs, name in split_use_tree(m.group(1)):
                if name == "*":
                    segs = segs[:-1]
                t = self.resolve(here, segs)
                if t is not None:
                    out.append((line_of(m.start()), here, t))
        path_re = re.compile(r"(?<![A-Za-z0-9_:$])(" + IDENT + r")(\s*::\s*" + IDENT + r")+")
        for m in path_re.finditer(code):
            if any(a <= m.start() < b for a, b in used):
                continue
            segs = [s.strip() for s in m.group(0).split("::")]
            here = here_at(m.start())
            if segs[0] not in ("crate", "super", "self") and tuple(here + [segs[0]]) not in self.modules:
                continue
            t = self.resolve(here, segs)
            if t is not None:
                out.append((line_of(m.start()), here, t))
        return out


def tarjan(nodes, edges):
    index, low, on, st, res, k = {}, {}, set(), [], [], [0]

    def visit(v):
        index[v] = low[v] = k[0]
        k[0] += 1
        st.append(v)
        on.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = st.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            res.append(sorted(comp))

    for v in sorted(nodes):
        if v not in index:
            visit(v)
    return [c for c in res if len(c) > 1]


def circle(comp, edges):
    """One cycle through the component's first node (breadth-first back to it)."""
    start, inside = comp[0], set(comp)
    prev, queue = {start: None}, [start]
    while queue:
        v = queue.pop(0)
        for w in sorted(edges.get(v, ())):
            if w not in inside:
                continue
            if w == start:
                path = [v]
                while prev[path[-1]] is not None:
                    path.append(prev[path[-1]])
                return list(reversed(path)) + [start]
            if w not in prev:
                prev[w] = v
                queue.append(w)
    return comp + [start]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("src", help="the crate's src/ directory")
    ap.add_argument("--map", action="store_true", help="print every module file's imports")
    a = ap.parse_args()
    if not os.path.isdir(a.src):
        print(f"{a.src}: not a directory", file=sys.stderr)
        return 2
    crate = Crate(a.src)
    graphs = {}  # parent name ('' for the top level) -> {node: {target: [evidence]}}
    fmap = {}
    for path in sorted(crate.files):
        if crate.files[path] is None:
            continue
        rel = os.path.relpath(path, a.src)
        for line, src_mod, dst_mod in crate.imports(path):
            s, t = src_mod[:2], dst_mod[:2]
            if not t:
                continue
            fmap.setdefault(rel, set()).add("::".join(t))
            ev = f"{rel}:{line}"
            if s[0] != t[0]:
                graphs.setdefault("", {}).setdefault(s[0], {}).setdefault(t[0], []).append(ev)
            elif len(s) == 2 and len(t) == 2 and s[1] != t[1]:
                graphs.setdefault(s[0], {}).setdefault(s[1], {}).setdefault(t[1], []).append(ev)
    if a.map:
        for rel in sorted(fmap):
            print(f"{rel}: {', '.join(sorted(fmap[rel]))}")
        print()
    found = 0
    for parent in sorted(graphs):
        g = graphs[parent]
        nodes = set(g) | {t for v in g.values() for t in v}
        for comp in tarjan(nodes, g):
            found += 1
            where = "top-level modules" if not parent else f"modules of {parent}"
            name = (lambda x: x) if not parent else (lambda x: f"{parent}::{x}")
            print(f"cycle among {where}: {', '.join(name(c) for c in comp)}")
            cyc = circle(comp, g)
            for u, v in zip(cyc, cyc[1:]):
                ev = g[u][v]
                more = f" (+{len(ev) - 1} more)" if len(ev) > 1 else ""
                print(f"  {name(u)} -> {name(v)}   {ev[0]}{more}")
    n_mod = len({tuple(m[:2]) for m in crate.files.values() if m})
    if found:
        print(f"{a.src}: {found} cycle(s) among {n_mod} modules")
        return 1
    print(f"{a.src}: no import cycles among {n_mod} modules")
    return 0


if __name__ == "__main__":
    sys.exit(main())
