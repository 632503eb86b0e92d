#!/usr/bin/env python3
"""Every command shown in the docs runs in a test (issue 24).

  doc_commands.py list SOURCE_DIR                 every command of the docs' shell blocks, as the manifest keys it
  doc_commands.py check SOURCE_DIR [--build DIR] [--shared-data DIR] [--set run|slow|none]
                  [--jobs N] [--only REGEX] [--keep] [--self-test]

The commands are the lines of the shell code blocks (```sh, ```bash, ```console, ```shell, and
plain ``` blocks whose lines start like a command) of README.md and docs/*.md: comment lines are
skipped, a trailing `# comment` is dropped, a `$ ` prompt is removed (in a console block only the
prompted lines are commands), a line ending in `\\` and an indented line of arguments under a
command (starting with -, [, ( or |: the usage lines of README's "Commands") continue it (another
indented line is a note, skipped), and a here-document or a for/while/if block is one command up to
its end. A command is keyed by its file and its text with runs of white space made one.

tests/docs/doc_commands.json classifies every one of them:
  "run"           the fast set (CTest docs.commands, label unit): executed, must exit with "exit" (0)
  "slow"          the slow set (CTest docs.commands_slow, label slow): executed the same way
  "ctest:NAME"    exactly what the existing CTest NAME runs (checked to exist: `ctest -N` or tests/CMakeLists.txt)
  "skip:REASON"   cannot run inside a test at all (installs packages, is the test run itself, ...)
A run or slow entry executes "run" instead of the docs' text when the docs show placeholders
(CASE, DIR, [--optional] flags, a|b alternatives) or a big input: the concrete command with small
inputs; "setup" lines run first (they must succeed), "after" names earlier commands of the same file
to run first, "prefix" is put before the command (variables an earlier line set), "timeout" is in
seconds, "exit" the exit code the docs give it, "expect" a regex the output must match, and "needs"
the optional programs or built files it uses (ccx, xvfb-run, build/python): without them the
command is skipped with a message, unless CI is set. The commands of one docs file run in order in
one scratch folder shaped like the repository (build -> the build folder, the sources linked, an
empty docs/images; ../shared/data -> the real data), with the build folder on PATH and
OMP_NUM_THREADS=1; files run in parallel (--jobs).

`check` fails when a docs command is not in the manifest, when a manifest entry matches no docs
command any more (stale), when a ctest: entry names no test, when a `socketsmith <command>` line
shows a flag that the command's --help (docs/cli.md) does not list (a usage line runs here as a
concrete command, so its own flags are checked this way), or when a command of the chosen set
fails or times out. Without the shared data folder the listing is checked and the run skipped (77).
--self-test first shows that an unlisted command, a stale entry and a flag the command lacks are
each caught (and that the extraction reads prompts, continuations, here-documents and loops).
"""
import concurrent.futures
import glob
import json
import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time

MANIFEST = "tests/docs/doc_commands.json"
SHELL_LANGS = {"sh", "bash", "console", "shell", "shell-session"}
COMMAND_START = re.compile(r"^(\$ |socketsmith|build/|scripts/|tests/|python3|/usr/bin/python3|ctest|cd |xvfb-run|"
                           r"sudo |git |for |[A-Z_]+=)")
SKIP_EXIT = 77


def docs_files(source_dir):
    return ["README.md"] + sorted(os.path.relpath(p, source_dir) for p in glob.glob(os.path.join(source_dir, "docs", "*.md")))


def code_blocks(text):
    """(language, first line number, lines) of every fenced block."""
    blocks, inside, lang, start, body = [], False, "", 0, []
    for number, line in enumerate(text.split("\n"), 1):
        m = re.match(r"^\s*```\s*([\w-]*)", line)
        if m and not inside:
            inside, lang, start, body = True, m.group(1).lower(), number + 1, []
        elif m and inside:
            blocks.append((lang, start, body))
            inside = False
        elif inside:
            body.append(line)
    return blocks


def strip_comment(line):
    """The line without a trailing shell comment (a # at a word start, outside quotes)."""
    quote, prev = None, " "
    for i, c in enumerate(line):
        if quote:
            if c == quote:
                quote = None
        elif c in "'\"":
            quote = c
        elif c == "#" and prev in " \t;":
            return line[:i].rstrip()
        prev = c
    return line.rstrip()


def open_compounds(text):
    words = re.findall(r"(?:^|[\s;&|(])(for|while|until|if|do|done|fi|then)(?=[\s;]|$)", text)
    return words.count("do") + words.count("then") - words.count("done") - words.count("fi")


def block_commands(lang, lines):
    """The commands of one block: (text to run, first line index)."""
    if lang not in SHELL_LANGS:
        if lang or not any(COMMAND_START.match(l.strip()) for l in lines if l.strip()):
            return []
    console = lang in ("console", "shell-session") or any(l.startswith("$ ") for l in lines)
    commands, current, heredoc = [], None, None

    def finish():
        nonlocal current
        if current is not None:
            commands.append(current)
        current = None

    for i, raw in enumerate(lines):
        if heredoc is not None:  # the body of a here-document, kept verbatim
            current[0] += "\n" + raw
            if raw.strip() == heredoc:
                heredoc = None
                if open_compounds(current[0]) <= 0:
                    finish()
            continue
        prompted = raw.startswith("$ ")
        line = raw[2:] if prompted else raw
        if console and not prompted and not (current and (current[0].endswith("\\") or open_compounds(current[0]) > 0)):
            finish()  # a console block's output line
            continue
        if not line.strip() or line.strip().startswith("#"):
            if current is not None and not current[0].endswith("\\") and open_compounds(current[0]) <= 0:
                finish()
            continue
        code = strip_comment(line)
        inside = current is not None and (current[0].endswith("\\") or open_compounds(current[0]) > 0)
        if not inside and line[:1] in " \t" and not prompted and (current is None or not code.strip().startswith(("-", "[", "(", "|"))):
            finish()  # an indented note under a command ("options: ..."), not its arguments
            continue
        continues = inside or (current is not None and line[:1] in " \t" and not prompted and not console)
        if continues:
            current[0] = current[0][:-1].rstrip() + " " + code.strip() if current[0].endswith("\\") \
                else current[0] + "\n" + code
        else:
            finish()
            current = [code.strip(), i]
        m = re.search(r"<<-?\s*['\"]?(\w+)['\"]?", code)
        if m:
            heredoc = m.group(1)
    finish()
    return commands


def key_of(text):
    return " ".join(text.split())


def extract(source_dir):
    """[(file, line, key, text)] of every docs command, in docs order."""
    found = []
    for rel in docs_files(source_dir):
        with open(os.path.join(source_dir, rel), encoding="utf-8") as f:
            text = f.read()
        for lang, start, lines in code_blocks(text):
            for command, index in block_commands(lang, lines):
                found.append((rel, start + index, key_of(command), command))
    return found


def load_manifest(source_dir):
    with open(os.path.join(source_dir, MANIFEST), encoding="utf-8") as f:
        return json.load(f)["commands"]


def listing_problems(found, entries, known_tests):
    """Docs commands missing from the manifest, stale entries, bad classes."""
    problems = []
    listed = {(e["file"], key_of(e["command"])) for e in entries}
    shown = {(f, k) for f, _, k, _ in found}
    for f, line, k, _ in found:
        if (f, k) not in listed:
            problems.append(f"{f}:{line}: not in {MANIFEST} (add it as run, slow, ctest:NAME or skip:REASON): {k}")
    seen = set()
    for e in entries:
        ek = (e["file"], key_of(e["command"]))
        if ek not in shown:
            problems.append(f"{MANIFEST}: stale entry, {e['file']} shows no such command any more: {ek[1]}")
        if ek in seen:
            problems.append(f"{MANIFEST}: listed twice: {e['file']}: {ek[1]}")
        seen.add(ek)
        for prefix, o in zip(e.get("after", []), after_entries(e, [x for x in entries if x["file"] == e["file"]])):
            if o is None:
                problems.append(f"{MANIFEST}: {e['file']}: 'after' names no command of the file: {prefix}")
        cls = e.get("class", "")
        if cls.startswith("ctest:"):
            if known_tests is not None and not any(re.fullmatch(t, cls[6:]) for t in known_tests):
                problems.append(f"{MANIFEST}: {e['file']}: '{cls}' names no CTest test: {ek[1]}")
        elif cls.startswith("skip:"):
            if not cls[5:].strip():
                problems.append(f"{MANIFEST}: {e['file']}: a skip needs its reason: {ek[1]}")
        elif cls not in ("run", "slow"):
            problems.append(f"{MANIFEST}: {e['file']}: class '{cls}' is not run, slow, ctest:NAME or skip:REASON")
    return problems


def cli_flags(source_dir):
    """{command path: its flags} from docs/cli.md (the binary's --help, kept in step by docs.reference)."""
    with open(os.path.join(source_dir, "docs", "cli.md"), encoding="utf-8") as f:
        cli = f.read()
    return {tuple(m.group(1).split()): set(re.findall(r"(--[a-z][\w-]*)", m.group(2)))
            for m in re.finditer(r"^## socketsmith(.*?)\n(.*?)(?=^## |\Z)", cli, re.S | re.M)}


def flag_problems(found, sections):
    """A flag of a `socketsmith <command>` line that the command's --help does not list (a renamed or
    dropped flag in a usage line, which a concrete run in the manifest would not show)."""
    problems = []
    for f, line, key, _ in found:
        for m in re.finditer(r"(?:^|[\s/])socketsmith\s+(.*)", key):
            paths = [()]
            for word in m.group(1).split():  # the subcommand path; a|b: either
                deeper = [p + (a,) for p in paths for a in word.split("|") if p + (a,) in sections]
                if not deeper:
                    break
                paths = deeper
            known = set().union(*(sections[p] for p in paths))
            for flag in sorted(set(re.findall(r"(?<![\w-])(--[a-z][\w-]*)", m.group(1))) - known):
                problems.append(f"{f}:{line}: socketsmith {' '.join(paths[0])} has no flag {flag} (docs/cli.md): {key}")
    return problems


def known_test_names(source_dir, build_dir):
    """Regular expressions of the CTest names: `ctest -N`, tests/CMakeLists.txt and the GoogleTest sources."""
    names = set()
    if build_dir and os.path.isfile(os.path.join(build_dir, "CTestTestfile.cmake")):
        r = subprocess.run(["ctest", "-N"], cwd=build_dir, capture_output=True, text=True, timeout=120)
        names |= {re.escape(n) for n in re.findall(r"Test +#\d+: (\S+)", r.stdout)}
    with open(os.path.join(source_dir, "tests", "CMakeLists.txt"), encoding="utf-8") as f:
        cmake = f.read()
    names |= {n.replace(".", "\\.") for n in re.findall(r"add_test\(NAME ([^\s$]+)\s", cmake)}
    # a name made in a foreach loop (fuzz.cli_sweep_mutated_${kind}): any value of the variable
    names |= {re.sub(r"\\\$\\\{\w+\\\}", r"\\w+", re.escape(n)) for n in re.findall(r"add_test\(NAME (\S*\$\{\w+\}\S*)", cmake)}
    names |= {"cli\\." + n for n in re.findall(r"socketsmith_cli_test\((\w+)", cmake)}
    for path in glob.glob(os.path.join(source_dir, "tests", "**", "*.cpp"), recursive=True):
        with open(path, encoding="utf-8", errors="replace") as f:
            names |= {f"{a}\\.{b}" for a, b in re.findall(r"\bTEST(?:_F)?\((\w+), (\w+)\)", f.read())}
    return names


def make_scratch(root, source_dir, build_dir, shared_data):
    os.makedirs(os.path.join(root, "shared"))
    os.symlink(os.path.abspath(shared_data), os.path.join(root, "shared", "data"))
    repo = os.path.join(root, "repo")
    os.makedirs(os.path.join(repo, "docs", "images"))
    os.symlink(os.path.abspath(build_dir), os.path.join(repo, "build"))
    for name in os.listdir(source_dir):  # the sources (scripts/fuzz.sh configures its own tree from them)
        if name not in ("docs", "out", ".git") and not name.startswith("build"):
            os.symlink(os.path.join(os.path.abspath(source_dir), name), os.path.join(repo, name))
    return repo


def run_shell(script, cwd, env, timeout):
    """(exit code or None on timeout, seconds, the output)."""
    start = time.monotonic()
    p = subprocess.Popen(["bash", "-c", script], cwd=cwd, env=env, stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True, errors="replace", start_new_session=True)
    try:
        out, _ = p.communicate(timeout=timeout)
        code = p.returncode
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        out, _ = p.communicate()
        code = None
    return code, time.monotonic() - start, out


def tail_of(out):
    return "\n".join(out.strip().split("\n")[-12:])


def script_of(e, texts):
    """What an entry executes: its "prefix" (shell variables an earlier line of the block set), then
    its "run" or else the docs' own text."""
    run = e.get("run", texts[(e["file"], key_of(e["command"]))])
    return e.get("prefix", "") + ("\n".join(run) if isinstance(run, list) else run)


def after_entries(e, file_entries):
    """The entries of the same file named by e["after"] (key prefixes), in order."""
    chosen = []
    for prefix in e.get("after", []):
        match = [o for o in file_entries if key_of(o["command"]).startswith(key_of(prefix))]
        chosen.append(match[0] if match else None)
    return chosen


class Results(list):
    """(ok, message) of each command, printed as it comes."""

    def append(self, item):
        print(item[1], flush=True)
        super().append(item)


def run_group(rel, entries, args, env, texts, file_entries):
    """The entries of one docs file, in order, in one scratch folder: [(ok, message)]."""
    root = tempfile.mkdtemp(prefix="doc_commands_")
    results = Results()
    try:
        repo = make_scratch(root, args.source_dir, args.build, args.shared_data)
        for e in entries:
            name = f"{rel}: {key_of(e['command'])[:110]}"
            missing = [n for n in e.get("needs", []) if not (shutil.which(n) or os.path.exists(os.path.join(repo, n)))]
            if missing:  # an optional part (CalculiX, the GUI, the Python package) not installed or built
                results.append((not os.environ.get("CI"), f"skip {name}: no {', '.join(missing)}"
                                + (" (required when CI is set)" if os.environ.get("CI") else "")))
                continue
            script = "\n".join(e["setup"]) if isinstance(e.get("setup"), list) else e.get("setup", "")
            script = "\n".join([script_of(o, texts) for o in after_entries(e, file_entries)] + [script])
            if script.strip():
                code, secs, out = run_shell("set -e\n" + script, repo, env, e.get("timeout", 120))
                tail = tail_of(out)
                if code != 0:
                    results.append((False, f"FAIL {name}: setup exited {code} after {secs:.0f} s\n{tail}"))
                    continue
            run = script_of(e, texts)
            want = e.get("exit", 0)
            code, secs, out = run_shell(run, repo, env, e.get("timeout", 120))
            tail = tail_of(out)
            if code == want and e.get("expect") and not re.search(e["expect"], out):
                results.append((False, f"FAIL {name}: the output does not show /{e['expect']}/\n{tail}"))
            elif code == want:
                results.append((True, f"ok   {secs:6.1f} s  {name}"))
            elif code is None:
                results.append((False, f"FAIL {name}: timed out after {secs:.0f} s\n{tail}"))
            else:
                results.append((False, f"FAIL {name}: exit {code}, expected {want} ({secs:.0f} s)\n  ran: {run}\n{tail}"))
    finally:
        if args.keep:
            print(f"kept {root}")
        else:
            shutil.rmtree(root, ignore_errors=True)
    return results


def run_set(entries, args, texts, all_entries):
    env = dict(os.environ)
    env["PATH"] = os.path.abspath(args.build) + os.pathsep + env.get("PATH", "")
    env["OMP_NUM_THREADS"] = "1"
    env["PYTHONDONTWRITEBYTECODE"] = "1"
    groups = {}
    for e in entries:
        groups.setdefault(e["file"], []).append(e)
    # The longest files first, so the parallel runs end together.
    order = sorted(groups, key=lambda f: -sum(e.get("timeout", 120) for e in groups[f]))
    failures = 0
    with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
        futures = {pool.submit(run_group, f, groups[f], args, env, texts,
                               [e for e in all_entries if e["file"] == f]): f for f in order}
        for fut in concurrent.futures.as_completed(futures):
            failures += sum(not ok for ok, _ in fut.result())
    return failures


def self_test(found, entries, sections):
    base = listing_problems(found, entries, None)
    extra = found + [("README.md", 1, "build/socketsmith frobnicate --out DIR", "build/socketsmith frobnicate --out DIR")]
    caught = listing_problems(extra, entries, None)
    assert any("frobnicate" in p and "not in" in p for p in caught), "self-test: an unlisted command was not caught"
    dropped = [c for c in found if not (c[0] == entries[0]["file"] and c[2] == key_of(entries[0]["command"]))]
    caught = listing_problems(dropped, entries, None)
    assert any("stale entry" in p for p in caught) and len(caught) > len(base), "self-test: a stale entry was not caught"
    blocks = block_commands("console", ["$ build/socketsmith demo \\", "    --out DIR   # trailing", "[info] output"]) + \
        block_commands("sh", ["# a comment", "cat > x.json <<EOF", "{\"a\": 1}", "EOF", "for s in 1 2; do", "  echo $s", "done",
                              "build/socketsmith mesh --limb FILE", "       [--json]"])
    assert [key_of(c) for c, _ in blocks] == ["build/socketsmith demo --out DIR", "cat > x.json <<EOF {\"a\": 1} EOF",
                                               "for s in 1 2; do echo $s done", "build/socketsmith mesh --limb FILE [--json]"], \
        f"self-test: extraction: {blocks}"
    line = "build/socketsmith design CASE.json --out DIR [--time-limit S]"
    assert not flag_problems([("README.md", 1, line, line)], sections), "self-test: a known flag was refused"
    renamed = line.replace("--time-limit", "--time-limit-s")
    assert flag_problems([("README.md", 1, renamed, renamed)], sections), "self-test: a renamed flag was not caught"
    print("self-test: an unlisted docs command, a stale manifest entry and a flag the command lacks are each caught")


def parse_args(argv):
    import argparse
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("action", choices=["list", "check"])
    p.add_argument("source_dir")
    p.add_argument("--build", help="the build folder (socketsmith, socketsmith-gui, python/)")
    p.add_argument("--shared-data", help="the real data folder (SOCKETSMITH_SHARED_DATA_DIR)")
    p.add_argument("--set", default="none", choices=["run", "slow", "none"], help="which commands to execute")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--only", help="execute only the entries whose file or command matches this regex")
    p.add_argument("--keep", action="store_true", help="keep the scratch folders")
    p.add_argument("--self-test", action="store_true")
    return p.parse_args(argv)


def main(argv):
    args = parse_args(argv)
    found = extract(args.source_dir)
    if args.action == "list":
        for f, line, k, _ in found:
            print(f"{f}:{line}: {k}")
        return 0
    entries = load_manifest(args.source_dir)
    if args.self_test:
        self_test(found, entries, cli_flags(args.source_dir))
    problems = listing_problems(found, entries, known_test_names(args.source_dir, args.build))
    problems += flag_problems(found, cli_flags(args.source_dir))
    for p in problems:
        print(p)
    counts = {}
    for e in entries:
        cls = e["class"].split(":")[0]
        counts[cls] = counts.get(cls, 0) + 1
    print(f"{len(found)} docs commands: " + ", ".join(f"{n} {c}" for c, n in sorted(counts.items())))
    if problems:
        return 1
    if args.set == "none":
        return 0
    if not args.build or not os.path.isfile(os.path.join(args.build, "socketsmith")):
        print("no socketsmith in the build folder (--build): not running the commands")
        return 1
    if not args.shared_data or not os.path.isdir(args.shared_data):
        print(f"skipped: the shared data folder {args.shared_data} is absent (SOCKETSMITH_SHARED_DATA_DIR)")
        return SKIP_EXIT
    chosen = [e for e in entries if e["class"] == args.set
              and (not args.only or re.search(args.only, e["file"] + ": " + key_of(e["command"])))]
    start = time.monotonic()
    texts = {(f, k): text for f, _, k, text in found}
    failures = run_set(chosen, args, texts, entries)
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    print(f"{len(chosen) - failures} of {len(chosen)} '{args.set}' commands passed in {time.monotonic() - start:.0f} s "
          f"({usage.ru_utime + usage.ru_stime:.0f} s of CPU)")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
