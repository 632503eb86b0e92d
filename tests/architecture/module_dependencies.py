#!/usr/bin/env python3
"""The modules depend on each other only as docs/ARCHITECTURE.md draws them (CTest
architecture.module_dependencies).

The one table of allowed dependencies is the "depends on" column of ARCHITECTURE.md's module table,
read here, so the doc and the check cannot drift: the socketsmith module names in a row's column,
outside parentheses, are that module's direct dependencies; a module may use those and, through
them, what they depend on (the transitive closure). Third-party names (Eigen, CGAL, ...) are not
checked. Every `#include "socketsmith/<m>/..."` in src/socketsmith/<module>/ and every
`socketsmith::<m>` / `socketsmith_<m>` a module target links in src/socketsmith/CMakeLists.txt must
name the module itself or an allowed one; each violation is one line naming the file and line.

`--self-test` first adds a back edge in memory (calculix/calculix_deck.h including pipeline, the
calculix target linking pipeline) and requires both to be reported, so the check cannot pass by
reading nothing.

Usage: module_dependencies.py SOURCE_DIR [--self-test]   (standard library only)
"""
import pathlib
import re
import sys

DOC = "docs/ARCHITECTURE.md"
CMAKE = "src/socketsmith/CMakeLists.txt"
SOURCE_SUFFIXES = {".h", ".hpp", ".cpp", ".cc", ".inl"}
INCLUDE = re.compile(r'^\s*#\s*include\s*[<"]socketsmith/([A-Za-z0-9_]+)/[^">]*[">]')


class Tree:
    """The files of the source tree, with in-memory replacements (the self-test's back edges)."""

    def __init__(self, root, overlay=None):
        self.root = root
        self.overlay = overlay or {}

    def text(self, rel):
        if rel in self.overlay:
            return self.overlay[rel]
        return (self.root / rel).read_text(encoding="utf-8")

    def module_files(self, module):
        base = self.root / "src/socketsmith" / module
        return sorted(p.relative_to(self.root).as_posix() for p in base.rglob("*")
                      if p.is_file() and p.suffix in SOURCE_SUFFIXES)


def without_parentheses(text):
    out, depth = [], 0
    for ch in text:
        if ch == "(":
            depth += 1
        elif ch == ")":
            depth = max(0, depth - 1)
        elif depth == 0:
            out.append(ch)
    return "".join(out)


def read_table(tree, modules, errors):
    """{module: (set of direct dependencies, line of its row in the doc)} from the module table."""
    table = {}
    in_section = False
    for number, line in enumerate(tree.text(DOC).splitlines(), 1):
        if line.startswith("## "):
            in_section = line.startswith("## Modules")
            continue
        if not in_section or not line.startswith("|"):
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 3:
            continue
        name = cells[0].strip("`")
        if name not in modules:
            continue  # the header, apps/cli, apps/gui, python: not library modules
        deps = set()
        for item in without_parentheses(cells[-1]).split(","):
            words = item.strip().strip("`").split()
            if not words:
                continue
            word = words[0].strip("`")
            if word in ("all", "everything"):
                errors.append(f"{DOC}:{number}: the {name} row's 'depends on' says '{item.strip()}': "
                              "name the modules it depends on")
            elif word in modules and word != name:
                deps.add(word)
        table[name] = (deps, number)
    for m in sorted(modules - table.keys()):
        errors.append(f"src/socketsmith/{m}/: module without a row in {DOC}'s module table")
    return table


def closure(table):
    """{module: every module it may depend on}; cycles in the table are reported by the caller."""
    allowed = {}
    for m in table:
        seen, todo = set(), list(table[m][0])
        while todo:
            d = todo.pop()
            if d not in seen:
                seen.add(d)
                todo.extend(table.get(d, (set(), 0))[0])
        allowed[m] = seen
    return allowed


def cmake_commands(text):
    """(command, first argument, [(token, line)]) of every command, comments dropped."""
    commands = []
    pattern = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)\s*\(")
    lines = [re.sub(r"#.*", "", l) for l in text.splitlines()]
    flat = "\n".join(lines)
    pos = 0
    while True:
        m = pattern.search(flat, pos)
        if not m:
            break
        depth, i = 1, m.end()
        while i < len(flat) and depth:
            depth += {"(": 1, ")": -1}.get(flat[i], 0)
            i += 1
        body_start = m.end()
        tokens = []
        for t in re.finditer(r"[^\s()]+", flat[body_start:i - 1]):
            tokens.append((t.group(0), flat.count("\n", 0, body_start + t.start()) + 1))
        commands.append((m.group(1), tokens[0][0] if tokens else "", tokens))
        pos = i
    return commands


def check(tree):
    errors = []
    src = tree.root / "src/socketsmith"
    modules = {p.name for p in src.iterdir() if p.is_dir()}
    table = read_table(tree, modules, errors)
    allowed = closure(table)
    for m, (deps, line) in sorted(table.items()):
        if m in allowed[m]:
            errors.append(f"{DOC}:{line}: the module table has a cycle through {m}")

    def verdict(m):
        return ", ".join(sorted(allowed.get(m, ()))) or "nothing"

    includes = 0
    for m in sorted(table):
        for rel in tree.module_files(m):
            for number, text in enumerate(tree.text(rel).splitlines(), 1):
                hit = INCLUDE.match(text)
                if not hit:
                    continue
                includes += 1
                target = hit.group(1)
                if target != m and target not in allowed[m]:
                    errors.append(f"{rel}:{number}: {m} includes {target} ({text.strip()}) but {DOC}:{table[m][1]} "
                                  f"lets {m} depend on {verdict(m)}")

    links = 0
    target_name = re.compile(r"^socketsmith(?:::|_)([A-Za-z0-9_]+)$")
    for command, first, tokens in cmake_commands(tree.text(CMAKE)):
        if command == "socketsmith_module":
            owner = first
        elif command == "target_link_libraries" and target_name.match(first):
            owner = target_name.match(first).group(1)
        else:
            continue
        if owner not in modules:
            continue
        for token, number in tokens[1:]:
            hit = target_name.match(token)
            if not hit or hit.group(1) not in modules:
                continue  # socketsmith_warnings, socketsmith_cholmod, third-party targets
            links += 1
            dep = hit.group(1)
            if dep != owner and dep not in allowed.get(owner, ()):
                errors.append(f"{CMAKE}:{number}: the {owner} target links {token} but {DOC}:{table[owner][1]} "
                              f"lets {owner} depend on {verdict(owner)}")
    return errors, table, includes, links


def self_test(root):
    """A back edge added in memory must be reported with its file and line."""
    header = "src/socketsmith/calculix/calculix_deck.h"
    text = (root / header).read_text(encoding="utf-8")
    lines = text.splitlines()
    at = next(i for i, l in enumerate(lines) if INCLUDE.match(l))
    lines.insert(at, '#include "socketsmith/pipeline/design_pipeline.h"')
    cmake = (root / CMAKE).read_text(encoding="utf-8")
    cmake = cmake.replace("socketsmith_module(calculix\n", "socketsmith_module(calculix\n  PRIVATE_DEPS socketsmith::pipeline\n", 1)
    errors, _, _, _ = check(Tree(root, {header: "\n".join(lines) + "\n", CMAKE: cmake}))
    expected = [f"{header}:{at + 1}: calculix includes pipeline", "the calculix target links socketsmith::pipeline"]
    missing = [e for e in expected if not any(e in x for x in errors)]
    for e in missing:
        print(f"self-test: a back edge was not reported: expected a line with '{e}'", file=sys.stderr)
    return not missing


def main():
    root = pathlib.Path(sys.argv[1]).resolve()
    if "--self-test" in sys.argv[2:] and not self_test(root):
        return 1
    errors, table, includes, links = check(Tree(root))
    for e in errors:
        print(e, file=sys.stderr)
    if errors:
        print(f"{len(errors)} line(s) against {DOC}'s module table: fix the code, or the table if the new "
              "edge is the better shape (and say why there)", file=sys.stderr)
        return 1
    order = sorted(table, key=lambda m: (len(closure(table)[m]), m))
    print(f"{includes} includes and {links} links of {len(table)} modules follow {DOC} "
          f"(by depth: {', '.join(order)})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
