#!/usr/bin/env python3
"""Fails when a Rust crate's modules import each other in a circle.

    python3 scripts/check_module_cycles.py crates/isogrid-gpu/src

Builds the crate's module graph from its source files: module M depends on module N when M
declares `mod N;` (a parent depends on its children), or when M's code names a path into N
(`use crate::a::b`, `use super::x`, `self::y`, a relative path through one of M's child modules,
or such a path written inline, e.g. `crate::a::b::f()`). A path leads to the deepest module it
names, so `crate::render::Frame` makes M depend on `render` and `super::plan::FramePlan` on the
sibling `plan`. Inline `mod x { ... }` blocks (e.g. `#[cfg(test)] mod tests`) count as part of
their file; comments and string literals are ignored.

Since a parent depends on its children, a child that imports from its parent (or from any
ancestor, such as an item defined in `lib.rs`) closes a cycle: the crate root and other modules
that declare submodules are facades, and shared items live in modules of their own.

Prints every cycle found (one per strongly connected component, as `a -> b -> a`) and exits 1,
or prints the module count and exits 0.
"""
import os
import re
import sys

IDENT = r"[A-Za-z_][A-Za-z0-9_]*"


def strip(text):
    """The source with comments, strings and char literals blanked (newlines kept)."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            depth, i = 1, i + 2
            while i < n and depth:
                if text.startswith("/*", i):
                    depth, i = depth + 1, i + 2
                elif text.startswith("*/", i):
                    depth, i = depth - 1, i + 2
                else:
                    if text[i] == "\n":
                        out.append("\n")
                    i += 1
            out.append(" ")
        elif c == "r" and re.match(r'r#*"', text[i:i + 20]) and (i == 0 or not re.match(r"\w", text[i - 1])):
            hashes = re.match(r'r(#*)"', text[i:]).group(1)
            end = text.find('"' + hashes, i + 2 + len(hashes))
            end = n if end < 0 else end + 1 + len(hashes)
            out.append(" " + "\n" * text.count("\n", i, end))
            i = end
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append(" " + "\n" * text.count("\n", i, j))
            i = j + 1
        elif c == "'":
            m = re.match(r"'(\\.[^']*|[^\\'])'", text[i:])
            if m:
                out.append(" ")
                i += len(m.group(0))
            else:
                out.append(c)
                i += 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def module_files(src):
    """Module path (tuple of names, () for the crate root) -> file, for every .rs file under src."""
    modules = {}
    for root in ("lib.rs", "main.rs"):
        if os.path.exists(os.path.join(src, root)):
            modules[()] = os.path.join(src, root)
            break
    else:
        sys.exit(f"{src}: no lib.rs or main.rs")
    for dirpath, _, files in os.walk(src):
        for f in files:
            if not f.endswith(".rs"):
                continue
            rel = os.path.relpath(os.path.join(dirpath, f), src)
            parts = rel[:-3].split(os.sep)
            if parts[-1] == "mod":
                parts = parts[:-1]
            if parts in (["lib"], ["main"]) or parts == []:
                continue
            modules[tuple(parts)] = os.path.join(dirpath, f)
    return modules


def use_paths(tree, prefix=()):
    """Expands a use tree such as `a::{b, c::{d, e as f}}` into its paths (lists of names)."""
    tree = tree.strip()
    if not tree:
        return []
    # Split off a leading `a::b::` before a brace group.
    m = re.match(r"^((?:" + IDENT + r"\s*::\s*)*)\{(.*)\}$", tree, re.S)
    if m:
        head = [s for s in re.split(r"\s*::\s*", m.group(1)) if s]
        inner, parts, depth, cur = m.group(2), [], 0, ""
        for ch in inner:
            if ch == "{":
                depth += 1
            elif ch == "}":
                depth -= 1
            if ch == "," and depth == 0:
                parts.append(cur)
                cur = ""
            else:
                cur += ch
        parts.append(cur)
        paths = []
        for p in parts:
            paths += use_paths(p, prefix + tuple(head))
        return paths
    tree = re.sub(r"\s+as\s+" + IDENT + r"$", "", tree)
    segs = [s for s in re.split(r"\s*::\s*", tree) if s]
    return [list(prefix) + segs]


def file_edges(module, text, modules):
    """Modules that `module` (whose stripped source is `text`) depends on."""
    edges = set()
    children = {m[-1] for m in modules if len(m) == len(module) + 1 and m[:-1] == module}
    # Inline module blocks change what `self` and `super` mean inside them.
    scopes = []  # (brace depth at which the block opened, name)
    depth = 0
    tokens = re.finditer(r"\bmod\s+(" + IDENT + r")\s*([;{])|[{}]", text)
    events = []
    for t in tokens:
        if t.group(0) == "{":
            depth += 1
        elif t.group(0) == "}":
            depth -= 1
            while scopes and scopes[-1][0] > depth:
                scopes.pop()
                events.append((t.end(), tuple(s[1] for s in scopes)))
        elif t.group(2) == ";":
            name = t.group(1)
            if len(scopes) == 0:
                edges.add(module + (name,))
        else:
            depth += 1
            scopes.append((depth, t.group(1)))
            events.append((t.end(), tuple(s[1] for s in scopes)))

    def inline_scope(offset):
        scope = ()
        for at, s in events:
            if at <= offset:
                scope = s
            else:
                break
        return scope

    def resolve(segs, offset, relative_ok):
        here = module + inline_scope(offset)
        if segs[0] == "crate":
            base, rest = (), segs[1:]
        elif segs[0] in ("self", "super"):
            base, rest = here, segs
            while rest and rest[0] in ("self", "super"):
                if rest[0] == "super":
                    base = base[:-1]
                rest = rest[1:]
        elif relative_ok and here == module and segs[0] in children:
            base, rest = module, segs
        else:
            return None
        target = base
        for s in rest:
            if target + (s,) in modules:
                target = target + (s,)
            else:
                break
        # Inline modules live in the file: a path into one is a path into the file's module.
        while target not in modules:
            target = target[:-1]
        return target

    for m in re.finditer(r"\buse\s+([^;]*);", text):
        for segs in use_paths(m.group(1)):
            if segs and segs[0] == "::":
                continue
            t = resolve(segs, m.start(), True)
            if t is not None:
                edges.add(t)
    use_spans = [(m.start(), m.end()) for m in re.finditer(r"\buse\s+[^;]*;", text)]
    for m in re.finditer(r"(?<![\w:$])((?:" + IDENT + r")(?:\s*::\s*" + IDENT + r")+)", text):
        if any(a <= m.start() < b for a, b in use_spans):
            continue
        segs = re.split(r"\s*::\s*", m.group(1))
        t = resolve(segs, m.start(), True)
        if t is not None:
            edges.add(t)
    edges.discard(module)
    return edges


def cycles(graph):
    """One cycle per strongly connected component of more than one module (Tarjan)."""
    index, low, stack, on, comps, counter = {}, {}, [], set(), [], [0]

    def strongconnect(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                strongconnect(w)
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
                comps.append(set(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(graph):
        if v not in index:
            strongconnect(v)
    found = []
    for comp in comps:
        start = min(comp)
        # Shortest cycle through `start` inside the component (BFS back to it).
        prev, frontier, seen = {}, [start], {start}
        end = None
        while frontier and end is None:
            nxt = []
            for v in frontier:
                for w in sorted(graph[v] & comp):
                    if w == start:
                        end = v
                        break
                    if w not in seen:
                        seen.add(w)
                        prev[w] = v
                        nxt.append(w)
                if end is not None:
                    break
            frontier = nxt
        path = [end]
        while path[-1] != start:
            path.append(prev[path[-1]])
        path.reverse()
        found.append((path + [start], comp))
    return found


def name(module):
    return "crate" if not module else "::".join(module)


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__.strip().splitlines()[0] + "\nusage: check_module_cycles.py CRATE_SRC_DIR")
    src = sys.argv[1]
    if not os.path.isdir(src):
        sys.exit(f"{src}: not a directory")
    modules = module_files(src)
    graph = {}
    for module, path in modules.items():
        with open(path, encoding="utf-8") as f:
            graph[module] = file_edges(module, strip(f.read()), modules) & set(modules)
    found = cycles(graph)
    for cycle, comp in found:
        print(f"{src}: module cycle: " + " -> ".join(name(m) for m in cycle))
        if len(comp) > len(cycle) - 1:
            print(f"  (one of the cycles among: {', '.join(sorted(name(m) for m in comp))})")
    if found:
        sys.exit(1)
    print(f"{src}: {len(modules)} modules, no cycles")


if __name__ == "__main__":
    main()
