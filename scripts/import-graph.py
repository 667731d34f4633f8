#!/usr/bin/env python3
"""The workspace's file-level import graph: which source file uses which.

    python3 scripts/import-graph.py            # prints every cycle; exit 1 if any
    python3 scripts/import-graph.py --edges    # also prints every edge

Every `use` tree and every inline path (`crate::…`, `super::…`, `self::…`,
`pumptwin_<crate>::…`, `child_module::…`) in code (comments stripped, tests included) is resolved to the
file that defines the longest module prefix of it. `mod x;` declarations are structure,
not imports, and are not edges; a `pub use x::…` re-export is. A cycle is a strongly
connected set of two or more files.
"""
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CRATES = {  # crate name as used in paths -> src dir
    "pumptwin_core": "core/src",
    "pumptwin_data": "data/src",
    "pumptwin_twin": "twin/src",
    "pumptwin_trainer": "trainer/src",
    "pumptwin_edge": "edge-app/src",
    "pumptwin": "cli/src",
}


def module_of(path, src):
    rel = os.path.relpath(path, src)[:-3].split(os.sep)
    if rel[-1] in ("lib", "main", "mod"):
        rel = rel[:-1]
    return rel


def file_of(src, mods):
    """The file defining the longest prefix of module path `mods`."""
    for k in range(len(mods), -1, -1):
        base = os.path.join(src, *mods[:k]) if k else None
        if k == 0:
            for root in ("lib.rs", "main.rs"):
                f = os.path.join(src, root)
                if os.path.isfile(f):
                    return f
            return None
        for f in (base + ".rs", os.path.join(base, "mod.rs")):
            if os.path.isfile(f):
                return f
    return None


def strip_comments(text):
    """Code without comments, string or char literals (a small Rust scanner)."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            i = text.find("\n", i)
            i = n if i < 0 else i
        elif text.startswith("/*", i):
            depth, i = 1, i + 2
            while i < n and depth:
                if text.startswith("/*", i):
                    depth, i = depth + 1, i + 2
                elif text.startswith("*/", i):
                    depth, i = depth - 1, i + 2
                else:
                    i += 1
        elif c == "r" and re.match(r'r#*"', text[i:i + 8]) and not (i and (text[i - 1].isalnum() or text[i - 1] == "_")):
            hashes = re.match(r'r(#*)"', text[i:]).group(1)
            end = text.find('"' + hashes, i + len(hashes) + 2)
            i = n if end < 0 else end + 1 + len(hashes)
            out.append('""')
        elif c == '"':
            i += 1
            while i < n and text[i] != '"':
                i += 2 if text[i] == "\\" else 1
            i += 1
            out.append('""')
        elif c == "'" and re.match(r"'(\\.[^']*|[^\\'])'", text[i:i + 12]):
            m = re.match(r"'(\\.[^']*|[^\\'])'", text[i:i + 12])
            i += m.end()
            out.append("' '")
        else:
            out.append(c)
            i += 1
    return "".join(out)


def expand(tree):
    """`a::{b, c::{d, e}}` -> [a::b, a::c::d, a::c::e]"""
    tree = tree.strip()
    i = tree.find("{")
    if i < 0:
        return [tree]
    prefix, body = tree[:i], tree[i + 1 : tree.rfind("}")]
    parts, depth, cur = [], 0, ""
    for ch in body:
        if ch == "," and depth == 0:
            parts.append(cur)
            cur = ""
            continue
        depth += ch == "{"
        depth -= ch == "}"
        cur += ch
    parts.append(cur)
    return [prefix + q for p in parts if p.strip() for q in expand(p)]


def paths_in(text):
    """(path, inline module stack) of every use-tree leaf and inline path."""
    code = strip_comments(text)
    events = []  # (position, kind, payload)
    for m in re.finditer(r"\bmod\s+(\w+)\s*\{", code):
        events.append((m.end() - 1, "mod", m.group(1)))
    for m in re.finditer(r"[{}]", code):
        events.append((m.start(), m.group(0), None))
    for m in re.finditer(r"\buse\s+([^;]+);", code):
        for p in expand(m.group(1)):
            events.append((m.start(), "path", re.sub(r"\s+as\s+\w+$", "", p.strip())))
    for m in re.finditer(r"(?<![:\w])((?:[a-z_][a-z0-9_]*)(?:::\w+)+)", code):
        events.append((m.start(), "path", m.group(1)))
    events.sort(key=lambda e: (e[0], e[1] != "mod"))
    out, stack, depth, opened = [], [], 0, set()
    for pos, kind, payload in events:
        if kind == "mod":
            stack.append((payload, depth))
            opened.add(pos)
        elif kind == "{":
            depth += 1
        elif kind == "}":
            depth -= 1
            while stack and stack[-1][1] == depth:
                stack.pop()
        else:
            out.append((payload, [name for name, _ in stack]))
    return out


def resolve(path_str, here_src, here_mod):
    segs = [s for s in path_str.split("::") if s]
    if not segs:
        return None
    head = segs[0]
    if head == "crate":
        return file_of(here_src, segs[1:])
    if head in ("super", "self"):
        mod = list(here_mod)
        while segs and segs[0] in ("super", "self"):
            if segs.pop(0) == "super":
                mod = mod[:-1]
        return file_of(here_src, mod + segs)
    if head in CRATES:
        return file_of(os.path.join(ROOT, CRATES[head]), segs[1:])
    # 2018 paths: a child module of this one (`use child::Item`, `child::f()`).
    if file_of(here_src, here_mod + [head]) not in (None, file_of(here_src, here_mod)):
        return file_of(here_src, here_mod + segs)
    return None


def graph():
    edges = {}
    for name, src in CRATES.items():
        src = os.path.join(ROOT, src)
        for dirpath, _, files in os.walk(src):
            for f in files:
                if not f.endswith(".rs"):
                    continue
                path = os.path.join(dirpath, f)
                # a file-level module (`mod.rs`, `lib.rs`) is its directory's module;
                # `super` from `a/b.rs` is `a`.
                mod = module_of(path, src)
                targets = set()
                for p, inline in paths_in(open(path, encoding="utf-8").read()):
                    t = resolve(p, src, mod + inline)
                    if t and os.path.abspath(t) != os.path.abspath(path):
                        targets.add(os.path.relpath(t, ROOT))
                edges[os.path.relpath(path, ROOT)] = targets
    return edges


def cycles(edges):
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
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
    edges = graph()
    if "--edges" in sys.argv:
        for f in sorted(edges):
            for t in sorted(edges[f]):
                print(f"{f} -> {t}")
    found = cycles(edges)
    n = sum(len(v) for v in edges.values())
    print(f"{len(edges)} files, {n} import edges, {len(found)} cycles")
    for c in found:
        print("cycle:", " <-> ".join(c))
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
