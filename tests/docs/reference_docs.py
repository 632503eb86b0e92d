#!/usr/bin/env python3
"""The CLI and case-file references, kept in step with the built binary (issue 24).

  reference_docs.py SOCKETSMITH write-cli docs/cli.md    regenerate docs/cli.md from --help
  reference_docs.py SOCKETSMITH check SOURCE_DIR [--self-test]

`write-cli` runs `socketsmith --help` and, recursively, `--help` of every subcommand it lists,
and writes each page verbatim into docs/cli.md (scripts/gen_cli_reference.sh calls it).

`check` fails when
  - docs/cli.md differs from what `write-cli` would write now (a flag, default or range changed
    without regenerating the page: the diff is printed), or
  - the case file's keys that the parser accepts differ from the keys of docs/case_file.md's
    "Every key" table (either way round).
The accepted keys are read from the binary itself, not from the parser's source: a case file
with an unknown key in a section makes `socketsmith design` stop with
"unknown key 'K' in 'SECTION' (known: a, b, ...)" before anything runs; every known key is then
probed with an object to find the sections nested in it (and, when the parser answers that it wants
a list, with a list of one object: design.spots, brim.key_points). A sentinel
value out of range (`socket.subdivisions`) makes sure a probe that parses never starts a design.

--self-test first shows that the check catches drift: a flag added to one subcommand's help and a
key added to, or dropped from, the parser's answer must each make it fail.
"""
import difflib
import json
import os
import re
import subprocess
import sys
import tempfile

HEADER = """# Command-line reference

Every `socketsmith` command with its flags, defaults and ranges, exactly as `socketsmith <command>
--help` prints them. Generated from the built binary — do not edit by hand; regenerate with

```sh
scripts/gen_cli_reference.sh          # writes docs/cli.md from build/socketsmith
```

The CTest `docs.reference` (label `unit`) fails when this page and the binary disagree. What the
commands do and how they fit together: `README.md` ("Commands"), `docs/getting_started.md`; the case
file's keys: `docs/case_file.md`. Exit codes: 0 success, 1 bad input, 2 file error, 3 solver
diverged, 4 bad mesh topology, 70 internal error.
"""


def run_help(binary, path):
    # argv[0] is "socketsmith" whatever the binary's path, so the usage lines do not carry it.
    r = subprocess.run(["socketsmith", *path, "--help"], executable=binary, capture_output=True, text=True,
                       timeout=60)
    if r.returncode != 0:
        sys.exit(f"socketsmith {' '.join(path)} --help exited with {r.returncode}: {r.stderr.strip()}")
    return r.stdout


def subcommands(help_text):
    """The names under CLI11's 'Subcommands:' heading (its other headings end the list)."""
    names, inside = [], False
    for line in help_text.splitlines():
        if re.match(r"^[A-Za-z][A-Za-z ]*:$", line):
            inside = line.lower() == "subcommands:"
            continue
        m = re.match(r"^  (\S+)", line)
        if inside and m:
            names.append(m.group(1))
    return names


def cli_pages(binary):
    pages, todo = [], [[]]
    while todo:
        path = todo.pop(0)
        text = run_help(binary, path)
        pages.append((path, text))
        todo[0:0] = [path + [s] for s in subcommands(text)]  # depth first: a command, then its subcommands
    return pages


def render_cli(pages):
    out = [HEADER]
    out.append("## Commands\n")
    for path, _ in pages[1:]:
        name = " ".join(path)
        out.append(f"- [`socketsmith {name}`](#{anchor(name)})")
    out.append("")
    for path, text in pages:
        name = " ".join(["socketsmith", *path])
        out.append(f"## {name}\n")
        out.append("```text")
        out.append(text.rstrip("\n"))
        out.append("```\n")
    return "\n".join(out)


def anchor(name):
    return "socketsmith-" + re.sub(r"[^a-z0-9 -]", "", name.lower()).replace(" ", "-")


# ---- case file -----------------------------------------------------------------------------------

UNKNOWN = re.compile(r"unknown key '([^']*)' in '([^']*)' \(known: ([^)]*)\)")
PROBE = "zz_probe"


def set_path(doc, path, value):
    """path: list of keys; "[]" means a list of one object."""
    node = doc
    for i, key in enumerate(path):
        last = i == len(path) - 1
        if key == "[]":
            continue
        nxt = path[i + 1] if not last else None
        if last:
            node[key] = value
        elif nxt == "[]":
            node.setdefault(key, [{}])
            node = node[key][0]
        else:
            node.setdefault(key, {})
            node = node[key]


def ask_parser(binary, path, workdir):
    """Put {PROBE: 1} at path; return (section name, known keys), or (None, the error line) when
    the parser stopped for another reason."""
    doc = {}
    set_path(doc, path + [PROBE], 1)
    if path[:1] != ["socket"] or path[1:2] != ["subdivisions"]:
        # The sentinel: a case that parses is still refused before it runs (subdivisions are 0-3).
        doc.setdefault("socket", {}).setdefault("subdivisions", 99)
    case = os.path.join(workdir, "probe.json")
    with open(case, "w") as f:
        json.dump(doc, f)
    r = subprocess.run([binary, "design", case, "--out", os.path.join(workdir, "out")], capture_output=True,
                       text=True, timeout=60)
    if r.returncode == 0:
        sys.exit(f"probe {path} ran a design (exit 0): the sentinel did not stop it")
    m = UNKNOWN.search(r.stderr)
    if not m or m.group(1) != PROBE:
        return None, r.stderr.strip()
    return m.group(2), [k.strip() for k in m.group(3).split(",")]


def accepted_keys(binary):
    """Every dotted key the parser accepts: nested sections as 'a.b', lists of objects as 'a[].b';
    a section nested below the top level (socket.alignment, design.spots) is listed itself too."""
    keys = set()
    with tempfile.TemporaryDirectory() as tmp:
        todo = [([], "")]
        while todo:
            path, prefix = todo.pop(0)
            section, known = ask_parser(binary, path, tmp)
            if section is None:
                sys.exit(f"the parser did not name the keys of {path or 'the case'}: {known}")
            for k in known:
                dotted = prefix + k
                nested = False
                # An object in place of the key: a nested section answers with its known keys; a
                # list of objects says it wants a list, and is asked again with one.
                section, error = ask_parser(binary, path + [k], tmp)
                if section is not None:
                    todo.append((path + [k], dotted + "."))
                    nested = True
                elif "list" in error and ask_parser(binary, path + [k, "[]"], tmp)[0] is not None:
                    todo.append((path + [k, "[]"], dotted + "[]."))
                    nested = True
                if nested and prefix:
                    keys.add(dotted)  # a nested section below the top level is a key of its own too
                if not nested:
                    keys.add(dotted)
    return keys


def documented_keys(case_file_md):
    """The keys of the 'Every key' table: `a.b`, `a[].b`; a row may name several, comma separated."""
    with open(case_file_md) as f:
        text = f.read()
    m = re.search(r"^## Every key\n(.*?)(?=^## |\Z)", text, re.S | re.M)
    if not m:
        sys.exit(f"{case_file_md}: no '## Every key' section")
    keys = set()
    for line in m.group(1).splitlines():
        if not line.startswith("| `"):
            continue
        first_cell = line.split("|")[1]
        keys.update(re.findall(r"`([^`]+)`", first_cell))
    return keys


def key_drift(accepted, documented):
    problems = []
    for k in sorted(accepted - documented):
        problems.append(f"case file key '{k}' is accepted by the parser but not in docs/case_file.md's 'Every key'")
    for k in sorted(documented - accepted):
        problems.append(f"case file key '{k}' is in docs/case_file.md's 'Every key' but the parser refuses it")
    return problems


def cli_drift(expected, actual):
    if expected == actual:
        return []
    diff = difflib.unified_diff(actual.splitlines(), expected.splitlines(), "docs/cli.md", "socketsmith --help",
                                lineterm="")
    return ["docs/cli.md is not what the binary's --help prints (regenerate: scripts/gen_cli_reference.sh):",
            *list(diff)[:80]]


def check(binary, source_dir, self_test):
    pages = cli_pages(binary)
    generated = render_cli(pages)
    with open(os.path.join(source_dir, "docs", "cli.md")) as f:
        on_disk = f.read()
    accepted = accepted_keys(binary)
    documented = documented_keys(os.path.join(source_dir, "docs", "case_file.md"))
    if self_test:
        # A new flag on `design` without the doc, a new case key without the doc, a documented key
        # the parser dropped: each must be caught.
        edited = [(p, t.replace("Options:\n", "Options:\n  --new-flag FLOAT [1]  a flag added without its doc\n", 1)
                   if p == ["design"] else t) for p, t in pages]
        assert edited != pages, "self-test: could not add a flag to design's help"
        assert cli_drift(render_cli(edited), generated), "self-test: an added flag was not caught"
        assert key_drift(accepted | {"patient.new_key"}, accepted), "self-test: an added key was not caught"
        assert key_drift(accepted - {"limb.file"}, accepted | {"limb.file"}), "self-test: a dropped key was not caught"
        print("self-test: an added flag, an added key and a dropped key are each caught")
    problems = cli_drift(generated, on_disk) + key_drift(accepted, documented)
    print(f"{len(pages)} help pages, {len(accepted)} case-file keys accepted, {len(documented)} documented")
    if problems:
        print("\n".join(problems))
        return 1
    print("docs/cli.md and docs/case_file.md match the binary")
    return 0


def main(argv):
    if len(argv) >= 4 and argv[2] == "write-cli":
        with open(argv[3], "w") as f:
            f.write(render_cli(cli_pages(argv[1])))
        return 0
    if len(argv) >= 4 and argv[2] == "check":
        return check(argv[1], argv[3], "--self-test" in argv[4:])
    if len(argv) >= 3 and argv[2] == "keys":
        print("\n".join(sorted(accepted_keys(argv[1]))))
        return 0
    sys.exit(__doc__)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
