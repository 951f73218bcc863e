#!/usr/bin/env python3
"""Finds import cycles between the modules of one Rust crate.

Usage: python3 scripts/check_module_cycles.py CRATE_SRC_DIR [--edges]

A module is a file (`lib.rs`/`main.rs` is the crate root, `a/mod.rs` and `a.rs` are `a`,
`a/b.rs` is `a::b`). Module A depends on module B when A's code names a path into B: a `use`
(absolute `crate::`, relative `super::`/`self::`, or a child module's name) or a path in an
expression such as `super::cell_ray::max(..)`. A name re-exported by the crate root
(`pub use a::X;` in lib.rs) counts as a dependency on `a`, not on the root. Comments, doc links,
visibility clauses (`pub(super)`, `pub(in crate::a)`) and `#[cfg(test)]` inline modules are not
dependencies; a `mod child;` declaration is not one either. Prints every cycle found (one per
strongly connected component) and exits 1 if there is any; `--edges` also prints the graph.
"""
import os
import re
import sys

IDENT = r"[A-Za-z_][A-Za-z0-9_]*"


def module_of(src, path):
    rel = os.path.relpath(path, src)[:-3].split(os.sep)
    if rel in (["lib"], ["main"]):
        return ()
    if rel[-1] == "mod":
        rel = rel[:-1]
    return tuple(rel)


def strip_code(text):
    """The file's code without comments, string literals, visibility clauses and `#[cfg(test)]`
    inline modules."""
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    text = re.sub(r'"(?:\\.|[^"\\])*"', '""', text)
    text = "\n".join(line.split("//", 1)[0] for line in text.splitlines())
    text = re.sub(r"pub\s*\(\s*(?:in\s+[\w:]+|super|crate|self)\s*\)", "pub", text)
    # Drop `#[cfg(test)] mod name { ... }` by brace matching.
    out, i = [], 0
    pattern = re.compile(r"#\[cfg\(test\)\]\s*(?:pub\s+)?mod\s+\w+\s*\{")
    while True:
        m = pattern.search(text, i)
        if not m:
            out.append(text[i:])
            break
        out.append(text[i:m.start()])
        depth, j = 1, m.end()
        while j < len(text) and depth:
            depth += {"{": 1, "}": -1}.get(text[j], 0)
            j += 1
        i = j
    return "".join(out)


def use_paths(tree):
    """Expands a use tree (`a::{b, c::{d as e}}`) into its paths, each a list of segments."""
    tree = re.sub(r"\s+", "", tree)
    paths = []

    def walk(prefix, s):
        parts, depth, start = [], 0, 0
        for k, ch in enumerate(s):
            if ch == "{":
                depth += 1
            elif ch == "}":
                depth -= 1
            elif ch == "," and depth == 0:
                parts.append(s[start:k])
                start = k + 1
        parts.append(s[start:])
        for part in filter(None, parts):
            brace = part.find("{")
            if brace >= 0 and part.endswith("}"):
                head = [p for p in part[:brace].split("::") if p]
                walk(prefix + head, part[brace + 1:-1])
            else:
                segs = part.split("as")[0] if re.search(r"\bas\b", part) else part
                paths.append(prefix + [p for p in segs.split("::") if p])

    walk([], tree)
    return paths


def resolve(current, segs, modules):
    """The module a path starting at `current` leads into, or None for another crate."""
    if not segs:
        return None
    base = list(current)
    if segs[0] == "crate":
        base, segs = [], segs[1:]
    elif segs[0] == "super":
        while segs and segs[0] == "super":
            base, segs = base[:-1], segs[1:]
    elif segs[0] == "self":
        segs = segs[1:]
    elif tuple(base + [segs[0]]) not in modules:
        return None  # an external crate, a local item or a type's associated path
    target = tuple(base)
    for seg in segs:
        if tuple(list(target) + [seg]) in modules:
            target = tuple(list(target) + [seg])
        else:
            break
    return target


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    if len(args) != 1 or not os.path.isdir(args[0]):
        print(__doc__, file=sys.stderr)
        return 2
    src = args[0]
    files = {}
    for root, _, names in os.walk(src):
        for name in names:
            if name.endswith(".rs"):
                path = os.path.join(root, name)
                files[module_of(src, path)] = path
    modules = set(files)
    code = {m: strip_code(open(p, encoding="utf-8").read()) for m, p in files.items()}

    # Names the root re-exports, and the module each comes from.
    reexports = {}
    for m in re.finditer(r"\bpub\s+use\s+([^;]+);", code.get((), "")):
        for segs in use_paths(m.group(1)):
            target = resolve((), segs, modules)
            if target:
                reexports[segs[-1]] = target

    edges = {m: set() for m in modules}
    for module, text in code.items():
        paths = []
        for m in re.finditer(r"\buse\s+([^;]+);", text):
            paths += use_paths(m.group(1))
        for m in re.finditer(rf"(?<![\w:])((?:crate|super|self)(?:::{IDENT})+)", text):
            paths.append(m.group(1).split("::"))
        for segs in paths:
            target = resolve(module, segs, modules)
            if target == ():
                # `crate::X` or `super::X` reaching the root: the module that defines X, when
                # the root only re-exports it.
                rest = [s for s in segs if s not in ("crate", "super", "self")]
                target = reexports.get(rest[0], target) if rest else target
            if target is None or target == module:
                continue
            if module == () and segs[0] != "crate" and target[:1] == tuple(segs[:1]):
                continue  # the root naming its own children (`pub use a::X`, `mod a;`)
            edges[module].add(target)

    def name(m):
        return "::".join(m) or "crate"

    if "--edges" in sys.argv:
        for m in sorted(edges):
            print(f"{name(m)} -> {', '.join(sorted(name(t) for t in edges[m])) or '-'}")

    # Tarjan's strongly connected components; every component of two or more is a cycle.
    index, low, stack, on_stack, sccs = {}, {}, [], set(), []

    def strongconnect(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in edges[v]:
            if w not in index:
                strongconnect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            scc = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                scc.append(w)
                if w == v:
                    break
            if len(scc) > 1:
                sccs.append(scc)

    sys.setrecursionlimit(10000)
    for v in sorted(modules):
        if v not in index:
            strongconnect(v)

    for scc in sccs:
        members = set(scc)
        # One concrete cycle through the component, for the report.
        start = min(scc)
        path, seen = [start], {start}
        while True:
            nxt = sorted(w for w in edges[path[-1]] if w in members)
            back = [w for w in nxt if w == start]
            if back and len(path) > 1:
                break
            fresh = [w for w in nxt if w not in seen]
            if not fresh:
                break
            path.append(fresh[0])
            seen.add(fresh[0])
        print(f"cycle among {', '.join(sorted(name(m) for m in scc))}: "
              f"{' -> '.join(name(m) for m in path + [start])}")
    if sccs:
        return 1
    print(f"{src}: {len(modules)} modules, no import cycles")
    return 0


if __name__ == "__main__":
    sys.exit(main())
