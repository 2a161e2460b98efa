#!/usr/bin/env python3
# Run from the repository root: `python3 tools/file_cycles.py [-v]` (exit 1 if src/ has an import cycle between files).
"""Import cycles between the files of the library crate (src/**/*.rs, without src/main.rs).

Every `use crate::…`, `use super::…`, `use self::…` path, every inline `crate::…`/`super::…`/
`self::…` path, and every path that starts with a name a `use` brought in, is resolved to the
file that defines the item:

* module path → file: `crate::a::b` is `src/a/b.rs` or `src/a/b/mod.rs`, `crate` is `src/lib.rs`;
* a path into a module (`crate::a::b::Item`, or into an inline `mod` of that file) resolves to
  the longest prefix that is a module file;
* re-export hubs: when that file only re-exports the item (`pub use x::Item;`), the path is
  followed to the file that defines it. `mod x;` declarations are not dependencies, and neither
  are the `pub use` lines of `mod.rs`/`lib.rs` (namespaces); importing a module by name is not a
  dependency on the module's file either — only what is used through it is.

`#[cfg(test)]` items (inline `mod tests { … }`, `mod tests;` files and everything under them)
and every module called `tests` are ignored. The script prints the strongly connected
components of more than one file (each with the references that close it) and exits 1 if there
is one, 0 otherwise; `-v` also prints every edge.
"""

import os
import re
import sys
from collections import defaultdict

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
SRC = os.path.normpath(os.path.join(ROOT, "src"))


def strip_comments_and_strings(text):
    """Blanks comments, string and char literals (keeps offsets and newlines)."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
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
            out.append("".join(ch if ch == "\n" else " " for ch in text[i:j]))
            i = j
        elif c == "r" and re.match(r'r#*"', text[i:]) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            hashes = re.match(r"r(#*)\"", text[i:]).group(1)
            end = text.find('"' + hashes, i + 2 + len(hashes))
            end = n if end < 0 else end + 1 + len(hashes)
            out.append("".join(ch if ch == "\n" else " " for ch in text[i:end]))
            i = end
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            j += 1
            out.append("".join(ch if ch == "\n" else " " for ch in text[i:j]))
            i = j
        elif c == "'":
            # char literal ('a', '\n', '\u{..}') or lifetime ('a)
            m = re.match(r"'(\\.[^']*|[^\\'])'", text[i:])
            if m:
                out.append(" " * len(m.group(0)))
                i += len(m.group(0))
            else:
                out.append(c)
                i += 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def matching_brace(text, open_at):
    depth = 0
    for j in range(open_at, len(text)):
        if text[j] == "{":
            depth += 1
        elif text[j] == "}":
            depth -= 1
            if depth == 0:
                return j
    return len(text) - 1


CFG_TEST = re.compile(r"#\s*\[\s*cfg\s*\(\s*test\s*\)\s*\]")


def drop_test_items(text):
    """Blanks every item annotated `#[cfg(test)]` and every inline `mod tests { … }`."""
    text = list(text)
    s = "".join(text)
    spans = []
    for m in CFG_TEST.finditer(s):
        j = m.end()
        semi = s.find(";", j)
        brace = s.find("{", j)
        if brace >= 0 and (semi < 0 or brace < semi):
            end = matching_brace(s, brace)
        else:
            end = semi if semi >= 0 else len(s) - 1
        spans.append((m.start(), end + 1))
    for m in re.finditer(r"\bmod\s+tests\s*\{", s):
        spans.append((m.start(), matching_brace(s, m.end() - 1) + 1))
    for a, b in spans:
        for k in range(a, b):
            if text[k] != "\n":
                text[k] = " "
    return "".join(text)


def module_of_file(rel):
    """`a/b.rs` and `a/b/mod.rs` → ('a', 'b'); `lib.rs` → ()."""
    parts = rel[:-3].split("/")
    if parts[-1] in ("mod", "lib"):
        parts = parts[:-1]
    return tuple(parts)


def split_top(s, sep=","):
    parts, depth, cur = [], 0, []
    for ch in s:
        if ch == "{":
            depth += 1
        elif ch == "}":
            depth -= 1
        if ch == sep and depth == 0:
            parts.append("".join(cur))
            cur = []
        else:
            cur.append(ch)
    parts.append("".join(cur))
    return [p.strip() for p in parts if p.strip()]


def expand_use_tree(tree, prefix=()):
    """Yields (path segments, local name or None, is_glob) for a use tree."""
    tree = tree.strip()
    brace = tree.find("{")
    if brace >= 0 and tree.endswith("}"):
        head = [p for p in tree[:brace].split("::") if p.strip()]
        head = tuple(p.strip() for p in head)
        for sub in split_top(tree[brace + 1 : -1]):
            yield from expand_use_tree(sub, prefix + head)
        return
    alias = None
    m = re.match(r"(.*?)\s+as\s+(\w+)$", tree)
    if m:
        tree, alias = m.group(1), m.group(2)
    segs = tuple(p.strip() for p in tree.split("::") if p.strip())
    if segs and segs[-1] == "*":
        yield prefix + segs[:-1], None, True
        return
    if segs and segs[-1] == "self":
        full = prefix + segs[:-1]
        yield full, alias or (full[-1] if full else None), False
        return
    full = prefix + segs
    yield full, alias or (full[-1] if full else None), False


class Crate:
    def __init__(self):
        self.files = {}  # module tuple -> rel path
        self.text = {}  # rel path -> cleaned text
        self.test_files = set()
        for dirpath, _, names in os.walk(SRC):
            for name in names:
                if not name.endswith(".rs"):
                    continue
                rel = os.path.relpath(os.path.join(dirpath, name), SRC).replace(os.sep, "/")
                if rel == "main.rs" or rel.startswith("bin/"):
                    continue
                self.files[module_of_file(rel)] = rel
        raw = {}
        for mod, rel in self.files.items():
            with open(os.path.join(SRC, rel), encoding="utf-8") as f:
                raw[rel] = strip_comments_and_strings(f.read())
        # files declared under #[cfg(test)] (and everything below them, and `tests` modules)
        test_mods = set()
        for mod, rel in self.files.items():
            for m in re.finditer(CFG_TEST.pattern + r"\s*(?:pub(?:\([^)]*\))?\s+)?mod\s+(\w+)\s*;", raw[rel]):
                test_mods.add(mod + (m.group(1),))
        for mod, rel in self.files.items():
            if "tests" in mod or any(mod[: len(t)] == t for t in test_mods):
                self.test_files.add(rel)
        for mod, rel in self.files.items():
            self.text[rel] = drop_test_items(raw[rel])
        self.reexports = {rel: self._reexports(mod, rel) for mod, rel in self.files.items()}

    def is_hub(self, rel):
        return rel == "lib.rs" or rel.endswith("/mod.rs")

    def inline_modules(self, text):
        """[(start, end, name)] of inline `mod name { … }` blocks."""
        spans = []
        for m in re.finditer(r"\bmod\s+(\w+)\s*\{", text):
            spans.append((m.end() - 1, matching_brace(text, m.end() - 1), m.group(1)))
        return spans

    def module_at(self, mod, spans, pos):
        inner = [s for s in spans if s[0] < pos <= s[1]]
        inner.sort()
        return mod + tuple(s[2] for s in inner)

    def uses(self, mod, rel):
        """[(pos, module at pos, path, local name, glob, is_pub)] for every use statement."""
        text = self.text[rel]
        spans = self.inline_modules(text)
        out = []
        for m in re.finditer(r"(\bpub(?:\([^)]*\))?\s+)?\buse\s+([^;]+);", text):
            here = self.module_at(mod, spans, m.start())
            tree = re.sub(r"\s+", " ", m.group(2)).strip()
            for path, name, glob in expand_use_tree(tree):
                out.append((m.start(), m.end(), here, path, name, glob, bool(m.group(1))))
        return out

    def absolute(self, here, path):
        """Makes a path absolute (tuple without 'crate'); None for an external crate."""
        if not path:
            return None
        if path[0] == "crate":
            return tuple(path[1:])
        if path[0] in ("self", "super"):
            base = list(here)
            i = 0
            if path[0] == "self":
                i = 1
            while i < len(path) and path[i] == "super":
                base = base[:-1]
                i += 1
            return tuple(base) + tuple(path[i:])
        return None

    def _reexports(self, mod, rel):
        """name -> absolute path for the file's `pub use` items (top level of the file)."""
        result = {}
        for _, _, here, path, name, glob, is_pub in self.uses(mod, rel):
            if not is_pub or glob or here != mod:
                continue
            target = self.absolute(here, path)
            if target is None:
                # `pub use child::Item` (a child module of this file)
                if path and mod + (path[0],) in self.files:
                    target = mod + tuple(path)
                else:
                    continue
            result[name] = target
        return result

    def resolve(self, path, seen=None):
        """(file, exact module?) for an absolute path, following re-exports."""
        seen = seen or set()
        for k in range(len(path), -1, -1):
            prefix = path[:k]
            if prefix in self.files:
                rel = self.files[prefix]
                rest = path[k:]
                if not rest:
                    return rel, True
                target = self.reexports[rel].get(rest[0])
                if target is not None and (rel, rest[0]) not in seen:
                    seen.add((rel, rest[0]))
                    return self.resolve(target + rest[1:], seen)
                return rel, False
        return None, False

    def edges(self):
        edges = defaultdict(list)  # (from, to) -> [where]
        for mod, rel in self.files.items():
            if rel in self.test_files:
                continue
            text = self.text[rel]
            spans = self.inline_modules(text)
            aliases = {}  # (module at, local name) -> absolute path
            use_spans = []
            for start, end, here, path, name, glob, is_pub in self.uses(mod, rel):
                use_spans.append((start, end))
                target = self.absolute(here, path)
                if target is None and path and here + (path[0],) in self.files:
                    target = here + tuple(path)  # `use child::Item` (2018 relative path)
                if target is None:
                    continue
                if name:
                    aliases[(here, name)] = target
                if is_pub and self.is_hub(rel) and here == mod:
                    continue  # a namespace's re-export: followed by `resolve`
                dest, exact = self.resolve(target)
                if dest is None or (exact and not glob):
                    continue
                line = text.count("\n", 0, start) + 1
                edges[(rel, dest)].append(f"{rel}:{line} use {'::'.join(path)}")
            # paths in code
            code = list(text)
            for a, b in use_spans:
                for k in range(a, b):
                    if code[k] != "\n":
                        code[k] = " "
            code = "".join(code)
            for m in re.finditer(r"(?<![\w:])((?:[a-z_]\w*)(?:\s*::\s*[A-Za-z_]\w*)+)", code):
                segs = tuple(s.strip() for s in m.group(1).split("::"))
                here = self.module_at(mod, spans, m.start())
                target = None
                if segs[0] in ("crate", "self", "super"):
                    target = self.absolute(here, segs)
                else:
                    # a name brought in by `use` in this module or an enclosing one
                    scope = here
                    while True:
                        if (scope, segs[0]) in aliases:
                            target = aliases[(scope, segs[0])] + segs[1:]
                            break
                        if scope == mod or not scope:
                            break
                        scope = scope[:-1]
                    if target is None and here + (segs[0],) in self.files:
                        target = here + segs  # a child module
                if target is None:
                    continue
                dest, exact = self.resolve(target)
                if dest is None or exact:
                    continue
                line = text.count("\n", 0, m.start()) + 1
                edges[(rel, dest)].append(f"{rel}:{line} {'::'.join(segs)}")
        return {k: v for k, v in edges.items() if k[0] != k[1] and k[1] not in self.test_files}


def strongly_connected(nodes, succ):
    index, low, on, stack, out = {}, {}, set(), [], []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in succ.get(v, ()):
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
            out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(nodes):
        if v not in index:
            visit(v)
    return out


def main():
    verbose = "-v" in sys.argv[1:]
    crate = Crate()
    edges = crate.edges()
    succ = defaultdict(set)
    for a, b in edges:
        succ[a].add(b)
    if verbose:
        for (a, b), where in sorted(edges.items()):
            print(f"{a} -> {b}  ({where[0]}{' …' if len(where) > 1 else ''})")
    nodes = set(crate.files.values()) - crate.test_files
    cycles = [c for c in strongly_connected(nodes, succ) if len(c) > 1]
    print(f"{len(nodes)} files, {len(edges)} file dependencies, {len(cycles)} cycle(s)")
    for comp in sorted(cycles):
        members = set(comp)
        print(f"cycle of {len(comp)} files: {', '.join(comp)}")
        for (a, b), where in sorted(edges.items()):
            if a in members and b in members:
                print(f"  {a} -> {b}: {'; '.join(where[:3])}{' …' if len(where) > 3 else ''}")
    return 1 if cycles else 0


if __name__ == "__main__":
    sys.exit(main())
