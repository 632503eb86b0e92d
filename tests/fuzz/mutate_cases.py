#!/usr/bin/env python3
"""mutate_cases.py OUT_DIR COUNT [SEED]: writes COUNT fuzzed case files into OUT_DIR, mutated from
the seed corpora of scripts/fuzz.sh (tests/fuzz/corpus/case_file and design) with the words of its
dictionary (tests/fuzz/case_file.dict). Reproducible: the same SEED (default 1) gives the same files.

Two kinds of mutation, so the files reach past the JSON parser: about two thirds are parsed seeds
whose values are replaced by awkward ones (0, negatives, 1e400, NaN, wrong types, empty arrays,
dictionary words), whose keys are dropped, added or duplicated; the rest are libFuzzer-style byte
edits of a seed's text (bytes flipped, inserted or removed, a dictionary word inserted, the text
cut, two seeds spliced). Feed them to tests/fuzz/cli_sweep.sh. Python's standard library only.
"""
import json
import pathlib
import random
import sys

HERE = pathlib.Path(__file__).resolve().parent
# Raw JSON texts (not all valid JSON: 1e400 overflows a double, NaN is not JSON) put in place of a value.
AWKWARD = ["0", "-0", "-1", "1", "2", "0.5", "1e400", "-1e400", "1e-320", "1e20", "-1e20", "NaN", "Infinity",
           "2147483648", "-2147483649", "9007199254740993", "null", "true", "false", '""', '"x"', '"default"',
           "[]", "{}", "[0, 0, 0]", "[1e400, 0, 0]", '"\\u0000"', '"' + "a" * 300 + '"', "1.7976931348623157e308",
           "200", "199", "200000", "200001", "500", "-273"]


def load_dictionary(name="case_file.dict"):
    """The words of a libFuzzer dictionary of tests/fuzz, escapes decoded."""
    words = []
    for line in (HERE / name).read_text().splitlines():
        line = line.strip()
        if line.startswith('"') and line.endswith('"'):
            words.append(line[1:-1].encode().decode("unicode_escape"))
    return words


def paths(node):
    """Every (container, key) in a parsed JSON document, depth first."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else []
    for key, value in items:
        yield node, key
        yield from paths(value)


def structured(rng, doc, words):
    keys = [w.strip('"') for w in words if w.startswith('"') and w.endswith('"')]
    marker = 0
    raw = {}
    for _ in range(rng.randint(1, 3)):
        spots = list(paths(doc))
        what = rng.random()
        if not spots or what < 0.15:
            # A key of the dictionary added to the top or to a section, with an awkward value.
            target = doc
            sections = [v for v in doc.values() if isinstance(v, dict)] if isinstance(doc, dict) else []
            if sections and rng.random() < 0.7: target = rng.choice(sections)
            if isinstance(target, dict):
                token = f"@@{marker}@@"; marker += 1
                raw[token] = rng.choice(AWKWARD + [json.dumps(rng.choice(keys))] if keys else AWKWARD)
                target[rng.choice(keys) if keys else "x"] = token
            continue
        container, key = rng.choice(spots)
        if what < 0.7:
            token = f"@@{marker}@@"; marker += 1
            raw[token] = rng.choice(AWKWARD)
            container[key] = token
        elif what < 0.85:
            del container[key]
        elif isinstance(container, list):
            container.append(json.loads(json.dumps(container[key])))  # a spot or point twice
        else:
            value = container[key]
            container[key] = [value] if not isinstance(value, list) else {"x": value}
    text = json.dumps(doc)
    for token, value in raw.items():
        text = text.replace(json.dumps(token), value)
    return text.encode()


def bytewise(rng, data, other, words):
    data = bytearray(data)
    for _ in range(rng.randint(1, 4)):
        what = rng.random()
        pos = rng.randrange(len(data) + 1)
        if what < 0.2 and data:
            data[min(pos, len(data) - 1)] ^= 1 << rng.randrange(8)
        elif what < 0.35:
            data[pos:pos] = bytes([rng.randrange(256)])
        elif what < 0.5 and data:
            del data[pos:pos + rng.randint(1, 8)]
        elif what < 0.75:
            data[pos:pos] = rng.choice(words).encode()
        elif what < 0.85:
            del data[pos:]
        else:
            cut = rng.randrange(len(other) + 1)
            data = data[:pos] + bytearray(other[cut:])
    return bytes(data)


def arguments(argv, doc):
    """OUT_DIR COUNT [SEED] as (folder, count, random generator), or None after printing @p doc."""
    if len(argv) not in (2, 3):
        print(doc)
        return None
    return pathlib.Path(argv[0]), int(argv[1]), random.Random(int(argv[2]) if len(argv) == 3 else 1)


def main(argv):
    if (args := arguments(argv, __doc__)) is None:
        return 2
    out, count, rng = args
    seeds = [p.read_bytes() for d in ("case_file", "design") for p in sorted((HERE / "corpus" / d).iterdir())]
    words = load_dictionary()
    out.mkdir(parents=True, exist_ok=True)
    for i in range(count):
        seed = rng.choice(seeds)
        try:
            doc = json.loads(seed)
        except (ValueError, RecursionError):
            doc = None
        if doc is not None and rng.random() < 0.67:
            data = structured(rng, doc, words)
        else:
            data = bytewise(rng, seed, rng.choice(seeds), words)
        (out / f"case_{i:04d}.json").write_bytes(data)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
