#!/usr/bin/env python3
"""The house rules of src/ that a reader can check by counting
(docs/ARCHITECTURE.md, "Layers"):

- no import cycle between files: no file imports one that imports it back,
  directly or through others;
- no module imports one of a higher layer;
- no file over 600 lines; no ROS adapter (src/ros/) over 210 code lines
  (mod.rs, convert.rs, params.rs and log.rs are shared helpers);
- no function over 80 lines outside test code (and a tests/ folder), from
  its `fn` line to its closing brace.

Imports are read from `use` lines and `crate::`/`super::`/`self::` paths,
outside test code (after `#[cfg(test)]`, or a file `tests.rs`); a path names
the longest prefix that is a file.
Exit 1 with one line per finding, 0 when there is none.
"""
import os
import re
import sys

LAYERS = [
    ["params", "wrench", "contact", "outputs"],
    ["biotac", "record", "kinematics", "sim", "nail", "sensor"],
    ["learn"],
    ["control", "calibration"],
    ["nodes"],
    ["runtime", "report"],
    ["ros", "commands", "bin"],
]
MAX_LINES = 600
MAX_ROS_CODE_LINES = 210
ROS_HELPERS = {"mod.rs", "convert.rs", "params.rs", "log.rs"}
MAX_FN_LINES = 80
FN_START = re.compile(r"^(\s*)(pub(\([^)]*\))? )?(async )?(const )?(unsafe )?fn (\w+)")


def layer_of(module):
    top = module[0] if module else ""
    for i, names in enumerate(LAYERS):
        if top in names:
            return i
    return None


def modules(src):
    """File path -> module path (a tuple), for the library and the binary."""
    found = {}
    for d, _, files in os.walk(src):
        for f in files:
            if not f.endswith(".rs"):
                continue
            path = os.path.join(d, f)
            parts = os.path.relpath(path, src)[:-3].split(os.sep)
            if parts[-1] == "mod":
                parts = parts[:-1]
            if parts in (["lib"], ["main"]):
                parts = []
            found[path] = tuple(parts)
    return found


def non_test(text, path=""):
    """`text` without the items under `#[cfg(test)]`: each such item (a
    `mod tests;` line, or an item to its closing brace) is cut, what follows
    it kept."""
    if os.path.basename(path) == "tests.rs":
        return ""
    out, at = [], 0
    while (i := text.find("#[cfg(test)]", at)) >= 0:
        out.append(text[at:i])
        j = i + len("#[cfg(test)]")
        semi, brace = text.find(";", j), text.find("{", j)
        if brace < 0 or 0 <= semi < brace:
            at = len(text) if semi < 0 else semi + 1
            continue
        depth = 0
        for k in range(brace, len(text)):
            depth += {"{": 1, "}": -1}.get(text[k], 0)
            if depth == 0:
                break
        at = k + 1
    out.append(text[at:])
    return "".join(out)


def use_paths(tree):
    """The paths of one `use` tree: `a::{b, c::d}` -> a::b, a::c::d."""
    tree = re.sub(r"\s+", "", tree)
    out = []

    def walk(prefix, t):
        if not t:
            return
        if "{" not in t:
            out.append(prefix + [p for p in t.split(" as ")[0].split("::") if p])
            return
        i = t.index("{")
        head = [p for p in t[:i].split("::") if p]
        depth, part = 0, ""
        for ch in t[i + 1 : t.rindex("}")]:
            if ch == "," and depth == 0:
                walk(prefix + head, part)
                part = ""
                continue
            depth += {"{": 1, "}": -1}.get(ch, 0)
            part += ch
        walk(prefix + head, part)

    walk([], tree)
    return out


def imports(path, module, by_module, is_dir_module):
    text = re.sub(r"//[^\n]*", "", non_test(open(path).read(), path))
    paths = []
    for m in re.finditer(r"\buse\s+([^;]+);", text):
        paths += use_paths(m.group(1))
    for m in re.finditer(r"\b((?:crate|super|self)(?:::[A-Za-z_]\w*)+)", text):
        paths.append(m.group(1).split("::"))
    # The binary's `crate` is main.rs: its modules sit under src/ too.
    targets = set()
    for p in paths:
        if p[0] == "crate":
            base, rest = [], p[1:]
        elif p[0] in ("super", "self"):
            base, rest = list(module), p
            while rest and rest[0] in ("super", "self"):
                if rest[0] == "super":
                    base = base[:-1]
                rest = rest[1:]
        else:
            continue
        full = base + rest
        for n in range(len(full), 0, -1):
            if tuple(full[:n]) in by_module:
                if tuple(full[:n]) != module:
                    targets.add(tuple(full[:n]))
                break
    return targets


def long_functions(text):
    """(name, lines) of each function over MAX_FN_LINES in `text`."""
    lines, found, i = text.splitlines(), [], 0
    while i < len(lines):
        m = FN_START.match(lines[i])
        if m and not lines[i].rstrip().endswith(";"):
            end = m.group(1) + "}"
            j = i + 1
            while j < len(lines) and lines[j].rstrip() != end:
                j += 1
            if j - i + 1 > MAX_FN_LINES:
                found.append((m.group(7), j - i + 1))
            i = j
        i += 1
    return found


def code_lines(path):
    lines = non_test(open(path).read()).splitlines()
    return sum(1 for l in lines if l.strip() and not l.strip().startswith("//"))


def cycles(edges):
    """Strongly connected components of more than one file."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]
    sys.setrecursionlimit(10000)

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges[v]:
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
                out.append(comp)

    for v in edges:
        if v not in index:
            visit(v)
    return out


def main(src="src"):
    files = modules(src)
    by_module = {m: p for p, m in files.items()}
    name = lambda m: "/".join(m) or "lib"
    edges, findings = {}, []
    for path, module in files.items():
        is_dir = path.endswith("mod.rs")
        edges[module] = imports(path, module, by_module, is_dir)
        own = layer_of(module)
        for t in edges[module]:
            theirs = layer_of(t)
            if own is not None and theirs is not None and theirs > own:
                findings.append(
                    f"{path}: imports {name(t)} (layer {theirs}) from layer {own}"
                )
        n = len(open(path).read().splitlines())
        if n > MAX_LINES:
            findings.append(f"{path}: {n} lines (at most {MAX_LINES})")
        if module[:1] == ("ros",) and os.path.basename(path) not in ROS_HELPERS:
            c = code_lines(path)
            if c > MAX_ROS_CODE_LINES:
                findings.append(
                    f"{path}: {c} code lines (a ROS adapter: at most {MAX_ROS_CODE_LINES})"
                )
        rel = os.path.relpath(path, src)
        test_dir = "tests" in rel.split(os.sep)[:-1]
        for fn, n in [] if test_dir else long_functions(non_test(open(path).read(), path)):
            if n > MAX_FN_LINES:
                findings.append(f"{path}: fn {fn} is {n} lines (at most {MAX_FN_LINES})")
    for comp in cycles(edges):
        findings.append("import cycle: " + ", ".join(sorted(name(m) for m in comp)))
    for f in sorted(findings):
        print(f)
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
