#!/usr/bin/env python3
"""No block of six or more lines stands twice in src/ and apps/, alike but for names and values
(issue 24; CTest architecture.repeated_blocks).

Why: two copies of the same logic drift apart, and a fix lands in one of them. A block that
appears twice is a function, a table or a loop waiting to be written.

What is compared: every .h/.hpp/.cpp/.cc/.inl below src/ and apps/, read with comments, string
literals and preprocessor lines blanked out (the same reader as check_sizes.py). A line counts when
it holds more than punctuation and is not an access specifier. Each counted line is reduced to its
shape: a name (qualified or not) becomes `a`, a number `0`, a string or character literal `s`;
keywords, operators and punctuation stay. Two places repeat when six or more consecutive counted
lines have the same shapes; overlapping places in one file do not count.

Rows of a table are not logic: a window whose shapes repeat with a period of at most three lines
(a run of flags, the fields of a JSON object, a list of constants, one entry of two lines after
another) is not compared. What remains and is data or declarations by nature — a table whose rows
are longer than three lines, two classes' member lists — is listed in ALLOWED with the reason and
the number of repeated places it may hold; the check fails when an allowed file pair holds more,
when a pair not listed appears, and when a listed pair holds fewer (lower or remove its line: the
list only shrinks).

Usage: check_repeats.py [ROOT] [--report] [--self-test]   (standard library only)
  --report     list every repeated place with its lines, then check
  --self-test  first shows on in-memory files that a copied block is found (also when its names and
               numbers differ), that table rows are not, and that a grown allowed pair fails
"""
import itertools
import pathlib
import re
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from check_sizes import blank_out, functions  # noqa: E402  (the same reader and brace matcher)

WINDOW = 6
MAX_ROW_PERIOD = 3
FOLDERS = ("src", "apps")
SUFFIXES = {".h", ".hpp", ".cpp", ".cc", ".inl"}

# "pathA ~ pathB" (sorted, relative to the root; the same path twice for a pair in one file) ->
# (repeated places allowed, why they are data or declarations and not logic).
ALLOWED = {
}

KEYWORDS = set("""
alignas alignof and asm auto bool break case catch char char16_t char32_t char8_t class const
consteval constexpr constinit const_cast continue co_await co_return co_yield decltype default delete
do double dynamic_cast else enum explicit export extern false float for friend goto if inline int long
mutable namespace new noexcept not nullptr operator or private protected public register
reinterpret_cast requires return short signed sizeof static static_assert static_cast struct switch
template this thread_local throw true try typedef typeid typename union unsigned using virtual void
volatile wchar_t while override final
""".split())
TOKEN = re.compile(r'"[^"\n]*"|\'[^\'\n]*\'|[0-9][0-9A-Za-z_.\']*|[A-Za-z_][A-Za-z0-9_]*|::|->|\S')
# A declaration without logic — `type name;`, `type name = literal;`, `Type name{};`, an enumerator,
# `using a = b;` — is one row of a table whatever its type: they all have this shape.
DECLARATION = re.compile(r"^(?:(?:static|inline|constexpr|const|mutable|bool|int|double|float|char|unsigned|long|"
                         r"std::size_t|auto|a)\s+)*(?:[*&]\s*)?a(?:\s*=\s*-?\s*(?:a|0|s|true|false|nullptr))?"
                         r"(?:\s*\{\s*(?:a|0|s|true|false)?\s*\})?\s*[;,]$|^using a = a ;$")
TRIVIAL = re.compile(r"^[{}()\[\];,]*$|^(public|private|protected)\s*:$")


def shape(line):
    """The line with names, numbers and literals replaced by a, 0 and s; a qualified name is one name."""
    out = []
    for tok in TOKEN.findall(line):
        if tok[0] in "\"'":
            tok = "s"
        elif tok[0].isdigit():
            tok = "0"
        elif (tok[0].isalpha() or tok[0] == "_") and tok not in KEYWORDS:
            tok = "a"
        if tok == "a" and len(out) >= 2 and out[-1] == "::" and out[-2] == "a":
            out.pop()
            continue
        if tok == "::" and out and out[-1] == "a":
            out.append(tok)
            continue
        if out and out[-1] == "::" and tok != "a":
            out.pop()
        out.append(tok)
    flat = re.sub(r"\bs( s)+\b", "s", " ".join(out))
    return "declaration" if DECLARATION.match(flat) else flat


def counted_lines(text):
    """[[(line number, shape)] per function body]: the lines that count, function by function. A
    statement broken over lines inside its parentheses is one line (where it breaks follows the
    length of its names and strings), and adjacent string literals are one."""
    lines = blank_out(text).split("\n")
    bodies = []
    for _, first, last in functions(text):
        rows, depth = [], 0
        for number in range(first, last + 1):
            s = lines[number - 1].strip()
            continued = depth > 0 and rows
            depth = max(0, depth + s.count("(") + s.count("[") - s.count(")") - s.count("]"))
            if not s or TRIVIAL.match(s) and not continued:
                continue
            if continued:
                rows[-1] = (rows[-1][0], rows[-1][1] + " " + s)
            else:
                rows.append((number, s))
        bodies.append([(number, shape(s)) for number, s in rows])
    return bodies


def fold_table_rows(lines):
    """The counted lines with each run of table rows folded into one line: a stretch of at least three
    rows of one to MAX_ROW_PERIOD lines each, every row of the same shapes as the one before."""
    folded, i, n = [], 0, len(lines)
    while i < n:
        best = None
        for p in range(1, MAX_ROW_PERIOD + 1):
            k = i + p
            while k < n and lines[k][1] == lines[k - p][1]:
                k += 1
            rows = (k - i) // p
            if rows >= 3 and (best is None or rows * p > best[1]):
                best = (p, rows * p)
        if best is None:
            folded.append(lines[i] + (lines[i][0],))
            i += 1
            continue
        p, length = best
        folded.append((lines[i][0], "rows of: " + " | ".join(s for _, s in lines[i:i + p]), lines[i + length - 1][0]))
        i += length
    return folded


def find_repeats(files):
    """files: {path: text}. Returns [(pathA, (first, last), pathB, (first, last))], one per repeated place."""
    rows, index = {}, {}
    for path, text in files.items():
        lines = []
        for body in counted_lines(text):
            body = fold_table_rows(body)
            shapes = [row[1] for row in body]
            for i in range(len(body) - WINDOW + 1):  # a window stays inside one function
                index.setdefault(tuple(shapes[i:i + WINDOW]), []).append((path, len(lines) + i))
            lines += body
        rows[path] = lines
    # Window pairs, then chained into runs (a pair (a, i, b, j) continues (a, i - 1, b, j - 1)).
    pairs = set()
    for places in index.values():
        if len(places) > 16:  # a shape this common is punctuation-like, not a copied block
            continue
        for (pa, i), (pb, j) in itertools.combinations(sorted(places), 2):
            if pa == pb and abs(i - j) < WINDOW:
                continue
            pairs.add((pa, i, pb, j))
    runs = []
    for pa, i, pb, j in sorted(pairs):
        if (pa, i - 1, pb, j - 1) in pairs:
            continue
        k = 0
        while (pa, i + k + 1, pb, j + k + 1) in pairs:
            k += 1
        la, lb = rows[pa], rows[pb]
        runs.append((pa, (la[i][0], la[i + k + WINDOW - 1][-1]), pb, (lb[j][0], lb[j + k + WINDOW - 1][-1])))
    return runs


def pair_key(a, b):
    return " ~ ".join(sorted((a, b)))


def check(runs, allowed):
    """Messages for every pair of files whose repeated places exceed (or fall below) the allowance."""
    counts = {}
    for a, _, b, _ in runs:
        counts[pair_key(a, b)] = counts.get(pair_key(a, b), 0) + 1
    problems = []
    for key, n in sorted(counts.items()):
        limit = allowed.get(key, (0, ""))[0]
        if n > limit:
            problems.append(f"{key}: {n} repeated block(s) of {WINDOW}+ lines alike but for names and values "
                            f"(allowed {limit}); make the logic one function or table (--report shows the lines)")
    for key, (limit, _) in sorted(allowed.items()):
        if counts.get(key, 0) < limit:
            problems.append(f"{key}: now {counts.get(key, 0)} repeated block(s), allowed {limit}: lower or remove "
                            f"its line in ALLOWED (the list only shrinks)")
    return problems


def read_tree(root):
    files = {}
    for folder in FOLDERS:
        for p in sorted((root / folder).rglob("*")):
            if p.suffix in SUFFIXES and p.is_file():
                files[str(p.relative_to(root))] = p.read_text(encoding="utf-8", errors="replace")
    return files


def self_test():
    logic = ("int f(int x) {\n  int y = x * 2;\n  if (y > 3) y -= 1;\n  for (int i = 0; i < y; ++i) g(i);\n"
             "  auto z = h(y, x);\n  return z + y;\n}\n")
    renamed = logic.replace("f(", "k(").replace("y", "w").replace("2", "7").replace("h(", "q(")
    table = "".join(f'  add_option("--o{i}", flags.o{i}, "help {i}");\n' for i in range(12))
    files = {"src/a.cpp": logic, "src/b.cpp": renamed, "src/t.cpp": "void t() {\n" + table + "}\n",
             "src/u.cpp": "void u() {\n" + table.replace("add_option", "add_flag") + "}\n"}
    runs = find_repeats(files)
    assert [(a, b) for a, _, b, _ in runs] == [("src/a.cpp", "src/b.cpp")], runs
    assert check(runs, {}) and not check(runs, {"src/a.cpp ~ src/b.cpp": (1, "test")})
    assert check(runs + runs, {"src/a.cpp ~ src/b.cpp": (1, "test")}), "a grown allowed pair must fail"
    assert check([], {"src/a.cpp ~ src/b.cpp": (1, "test")}), "an allowance no longer used must fail"
    print("check_repeats self-test: a renamed copy is found, table rows are not, allowances are exact")


def main(argv):
    args = [a for a in argv if not a.startswith("--")]
    root = pathlib.Path(args[0] if args else pathlib.Path(__file__).resolve().parent.parent)
    if "--self-test" in argv:
        self_test()
    runs = find_repeats(read_tree(root))
    if "--report" in argv:
        for a, (a0, a1), b, (b0, b1) in runs:
            print(f"{a}:{a0}-{a1} ~ {b}:{b0}-{b1}")
    problems = check(runs, ALLOWED)
    for p in problems:
        print(p, file=sys.stderr)
    print(f"repeats: {len(runs)} repeated block(s) of {WINDOW}+ lines, "
          f"{sum(n for n, _ in ALLOWED.values())} allowed as data or declarations")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
