#!/usr/bin/env python3
"""No file over 600 lines and no function over 80 lines in src/ and apps/ (issue 24, "split the
long rooms"; CTest architecture.file_and_function_sizes).

Why: a file or a function past these sizes is usually several responsibilities in one room; the
limit makes a new one visible the day it appears instead of the day someone has to read it.

What is measured:
- a file's lines: every line of every .h/.hpp/.cpp/.cc/.inl below src/ and apps/;
- a function's lines: from the first line of its signature to its closing brace, for every function
  body opened at namespace or class level (a lambda or a local class inside a function counts as
  part of that function). The scan is a plain brace matcher over the text with comments, string and
  character literals and preprocessor lines blanked out; constructor initialiser braces
  (`: a_{x}`) are part of the signature, and a brace after `=` or a type name (an initialiser, a
  data table) is not a function.

Files that are data tables rather than code may be listed in DATA_TABLES with the reason; they are
not held to the file limit (their functions still are).

While rooms remain over the limits they are listed in ALLOWED_FILES / ALLOWED_FUNCTIONS with their
current size: the check fails when an allowed one grows, when a file or function not listed
crosses a limit, and when a listed one has come under its limit (remove its line: the list only
shrinks).

Usage: check_sizes.py [ROOT] [--report] [--allow-list] [--self-test]   (standard library only)
  --report     list every file and function over the limits with its size, then check
  --tighten    rewrite this script's allow-list after a split: drops the rooms now under their limit
               and lowers the sizes that shrank; it never adds a room nor raises a size
  --self-test  first shows on in-memory copies that a grown allowed file, a new long file and a new
               long function are each reported, so the check cannot pass by reading nothing
"""
import pathlib
import re
import sys

FILE_LIMIT = 600
FUNCTION_LIMIT = 80
FOLDERS = ("src", "apps")
SUFFIXES = {".h", ".hpp", ".cpp", ".cc", ".inl"}

# path -> why the file is a data table and not code.
DATA_TABLES = {
}

# Rooms over the limits today, with their size in lines; the list shrinks as they are split.
# Key: path relative to the root.
ALLOWED_FILES = {
}

# Key: "path:function" (the qualified name as written at its definition).
ALLOWED_FUNCTIONS = {
}


def blank_out(text):
    """Comments, string and character literals and preprocessor lines replaced by spaces, newlines
    kept, so that braces in them do not count and line numbers stay."""
    out = []
    i, n = 0, len(text)
    at_line_start = True
    while i < n:
        c = text[i]
        if at_line_start and c == "#":
            # A preprocessor line, with its continuations.
            while i < n and text[i] != "\n":
                if text[i] == "\\" and i + 1 < n and text[i + 1] == "\n":
                    out.append(" \n")
                    i += 2
                    continue
                out.append(" ")
                i += 1
            continue
        if c == "\n":
            out.append(c)
            at_line_start = True
            i += 1
            continue
        if c in " \t\r":
            out.append(c)
            i += 1
            continue
        at_line_start = False
        if text.startswith("//", i):
            while i < n and text[i] != "\n":
                out.append(" ")
                i += 1
            continue
        if text.startswith("/*", i):
            end = text.find("*/", i + 2)
            end = n if end < 0 else end + 2
            out.append(re.sub(r"[^\n]", " ", text[i:end]))
            i = end
            continue
        raw = re.match(r'(?:u8|u|U|L)?R"([^()\\ ]{0,16})\(', text[i:i + 24])
        if raw and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            close = ")" + raw.group(1) + '"'
            end = text.find(close, i + raw.end())
            end = n if end < 0 else end + len(close)
            out.append('"' + re.sub(r"[^\n]", " ", text[i + 1:end - 1]) + '"')
            i = end
            continue
        if c == '"' or (c == "'" and not (i > 0 and text[i - 1].isalnum())):
            # A string or character literal (a digit separator 1'000 is not one).
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            out.append(c + " " * (min(j, n) - i - 1) + (c if j < n else ""))
            i = j + 1
            continue
        out.append(c)
        i += 1
    return "".join(out)


SCOPE_KEYWORD = re.compile(r"\b(namespace|class|struct|union|enum)\b")
NAME_BEFORE_PAREN = re.compile(r"((?:[A-Za-z_~][A-Za-z0-9_]*\s*(?:<[^(){};]*>)?\s*::\s*)*"
                               r"(?:operator\s*[^\s(]+|operator\s*\(\s*\)|~?[A-Za-z_][A-Za-z0-9_]*))\s*\($")


def strip_template_prefix(flat):
    """A header without its leading `template <...>` clauses (their `class` names no scope)."""
    while True:
        m = re.match(r"\s*template\s*<", flat)
        if not m:
            return flat
        depth, k = 1, m.end()
        while k < len(flat) and depth:
            depth += {"<": 1, ">": -1}.get(flat[k], 0)
            k += 1
        flat = flat[k:]


def function_name(header):
    """The qualified name before the parameter list of a function header, or None."""
    depth = 0
    for k, ch in enumerate(header):
        if ch == "<":
            depth += 1
        elif ch == ">" and depth > 0:
            depth -= 1
        elif ch == "(":
            m = NAME_BEFORE_PAREN.search(header[:k + 1])
            if m:
                name = re.sub(r"\s+", "", m.group(1))
                if name not in {"decltype", "alignas", "noexcept", "requires", "__attribute__"}:
                    return name
    return None


def matching_brace(code, i):
    """The index of the brace that closes the one at i (len(code) when it is never closed)."""
    depth = 0
    for j in range(i, len(code)):
        if code[j] == "{":
            depth += 1
        elif code[j] == "}":
            depth -= 1
            if depth == 0:
                return j
    return len(code)


def functions(text):
    """[(name, first line, last line)] of the function bodies at namespace or class level."""
    code = blank_out(text)
    found = []
    # Stack of scopes: "ns" (namespace, class, extern block: functions may be defined here) or
    # "other" (an initialiser, an enum body).
    stack = []
    header_start = 0
    i, n = 0, len(code)
    while i < n:
        c = code[i]
        if c in ";}" and (not stack or stack[-1] == "ns"):
            if c == "}" and stack:
                stack.pop()
            header_start = i + 1
            i += 1
            continue
        if c == "}":
            stack.pop()
            i += 1
            continue
        if c != "{":
            i += 1
            continue
        if stack and stack[-1] != "ns":
            stack.append("other")
            i += 1
            continue
        header = code[header_start:i]
        flat = strip_template_prefix(" ".join(header.split()))
        before = flat.rstrip()
        if SCOPE_KEYWORD.search(flat.split("(")[0]) or re.search(r'\bextern\s+"\s*"\s*$', before) \
                or before.startswith("extern"):
            stack.append("other" if re.search(r"\benum\b", flat.split("(")[0]) else "ns")
            header_start = i + 1
            i += 1
            continue
        name = function_name(flat) if "(" in flat else None
        if name is None or before.endswith("=") or before.endswith(",") and ")" not in before:
            stack.append("other")
            i += 1
            continue
        if re.search(r"\)\s*(?:const\s*)?(?:noexcept\s*)?:\s*(?!:)", flat) and \
                (before[-1:].isalnum() or before[-1:] in "_>"):
            # A brace initialiser of a constructor's member list: part of the signature.
            j = matching_brace(code, i)
            i = j + 1
            continue
        # A function body: find its closing brace.
        j = matching_brace(code, i)
        lead = len(header) - len(header.lstrip())
        first = code.count("\n", 0, header_start + lead) + 1
        last = code.count("\n", 0, min(j, n)) + 1
        found.append((name, first, last))
        header_start = j + 1
        i = j + 1
    return found


def measure(root, overlay=None):
    """({path: lines} over the file limit, {"path:name": lines} over the function limit)."""
    overlay = overlay or {}
    paths = set(overlay)
    for folder in FOLDERS:
        base = root / folder
        if base.is_dir():
            paths.update(p.relative_to(root).as_posix() for p in base.rglob("*")
                         if p.suffix in SUFFIXES and p.is_file())
    long_files, long_functions = {}, {}
    for rel in sorted(paths):
        text = overlay[rel] if rel in overlay else (root / rel).read_text(encoding="utf-8")
        lines = text.count("\n") + (0 if text.endswith("\n") or not text else 1)
        if lines > FILE_LIMIT and rel not in DATA_TABLES:
            long_files[rel] = lines
        for name, first, last in functions(text):
            size = last - first + 1
            if size > FUNCTION_LIMIT:
                key = f"{rel}:{name}"
                long_functions[key] = max(size, long_functions.get(key, 0))
    return long_files, long_functions


def problems(long_files, long_functions, allowed_files, allowed_functions):
    out = []
    for what, limit, found, allowed in (("file", FILE_LIMIT, long_files, allowed_files),
                                        ("function", FUNCTION_LIMIT, long_functions, allowed_functions)):
        for key, size in sorted(found.items()):
            if key not in allowed:
                out.append(f"{key}: {what} of {size} lines is over the limit of {limit} "
                           f"(split it along its responsibilities)")
            elif size > allowed[key]:
                out.append(f"{key}: allowed {what} grew from {allowed[key]} to {size} lines "
                           f"(it is over the limit of {limit}: split it rather than grow it)")
        for key in sorted(set(allowed) - set(found)):
            out.append(f"{key}: {what} is no longer over {limit} lines: remove it from "
                       f"scripts/check_sizes.py's allow-list")
    return out


def self_test(root):
    """A grown allowed file, a new long file and a new long function must each be reported."""
    probe = "src/socketsmith/size_probe.cpp"
    body = "\n".join(["int probe_function(int x) {"] + ["  x += 1;"] * FUNCTION_LIMIT + ["  return x;", "}"])
    overlay = {probe: body + "\n" + "\n" * FILE_LIMIT}
    expected = [f"{probe}: file of", f"{probe}:probe_function: function of"]
    if ALLOWED_FILES:
        grown = sorted(ALLOWED_FILES)[0]
        overlay[grown] = (root / grown).read_text(encoding="utf-8") + "\n"
        expected.append(f"{grown}: allowed file grew")
    found = problems(*measure(root, overlay), ALLOWED_FILES, ALLOWED_FUNCTIONS)
    ok = True
    for e in expected:
        if not any(line.startswith(e) for line in found):
            print(f"self-test: not reported: expected a line starting with '{e}'", file=sys.stderr)
            ok = False
    return ok


def tighten(long_files, long_functions):
    """Rewrites ALLOWED_FILES / ALLOWED_FUNCTIONS in this file: entries still over their limit, each
    at the smaller of its allowed and its measured size."""
    me = pathlib.Path(__file__).resolve()
    text = me.read_text(encoding="utf-8")
    for name, allowed, found in (("ALLOWED_FILES", ALLOWED_FILES, long_files),
                                 ("ALLOWED_FUNCTIONS", ALLOWED_FUNCTIONS, long_functions)):
        kept = {k: min(v, found[k]) for k, v in allowed.items() if k in found}
        allowed.clear()
        allowed.update(kept)
        start = text.index(f"{name} = {{\n")
        end = text.index("\n}\n", start) + 3
        rows = "".join(f'    "{k}": {v},\n' for k, v in sorted(kept.items()))
        text = text[:start] + f"{name} = {{\n" + rows + "}\n" + text[end:]
    me.write_text(text, encoding="utf-8")


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    root = pathlib.Path(args[0] if args else pathlib.Path(__file__).resolve().parent.parent).resolve()
    if "--self-test" in sys.argv[1:] and not self_test(root):
        return 1
    long_files, long_functions = measure(root)
    if "--report" in sys.argv[1:]:
        print(f"files over {FILE_LIMIT} lines: {len(long_files)}")
        for key, size in sorted(long_files.items(), key=lambda kv: -kv[1]):
            print(f"  {size:5d}  {key}")
        print(f"functions over {FUNCTION_LIMIT} lines: {len(long_functions)}")
        for key, size in sorted(long_functions.items(), key=lambda kv: -kv[1]):
            print(f"  {size:5d}  {key}")
    if "--tighten" in sys.argv[1:]:
        tighten(long_files, long_functions)
    found = problems(long_files, long_functions, ALLOWED_FILES, ALLOWED_FUNCTIONS)
    for line in found:
        print(line, file=sys.stderr)
    if not found:
        print(f"sizes: {len(long_files)} file(s) over {FILE_LIMIT} lines and {len(long_functions)} "
              f"function(s) over {FUNCTION_LIMIT} lines, each on the allow-list at its size")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
