#!/usr/bin/env python3
"""mutate_meshes.py OUT_DIR COUNT [SEED]: writes COUNT fuzzed limb surfaces into OUT_DIR, mutated
from the mesh seeds of scripts/fuzz.sh: the formats' edge cases (tests/fuzz/corpus/stl, obj, ply)
and a tiny limb in each format (tests/fuzz/corpus/limb/tiny_limb*: 193 vertices, 368 triangles, an
open 100 x 150 mm limb; AAOP 12 spokes x 9 slices). Reproducible: the same SEED (default 1) gives
the same files; the inputs added to the corpus after a finding are not seeds, so the files stay the same.

Three kinds of mutation, so the files reach past the readers into the checks and the mesher:
- geometric (half): a parsed triangle seed (STL ASCII/binary, OBJ, PLY ASCII/binary; the tiny
  limb four times in five) gets one to three of: NaN/inf/huge coordinates, faces turned over
  (swapped), degenerate triangles (a repeated corner, three points on a line), duplicated
  triangles, a non-manifold fin on an edge, faces removed (holes), a second copy of the surface
  (two skins, 0-300 mm apart), unit confusion (scaled by 1000, 1/1000, 25.4, 1/25.4, 1e6, 1e-6),
  the surface moved 1e6 mm or more away, flattened or squashed, faces shuffled, one face or none
  left, vertices jittered so faces cross, faces fanned to one vertex; then written in a format drawn
  at random (STL ASCII or binary, OBJ, PLY ASCII or binary of either byte order), one in twelve
  with a header that lies (a binary STL's or a PLY's count far too large, an OBJ index past the
  end or negative);
- AAOP (a sixth): a seed's values replaced by awkward ones (0, negative, NaN, 1e400, 2^31 counts,
  words), radii and heights scaled (unit confusion), a line (a spoke, a slice) dropped, the file cut;
- bytes (the rest): a number sometimes made huge or awkward (or a binary STL's count changed),
  then mutate_cases.py's libFuzzer-style edits with the words of tests/fuzz/mesh.dict (bits
  flipped, bytes inserted or removed, a word inserted, the file cut, two seeds spliced).
Feed them to tests/fuzz/cli_sweep.sh (docs/fuzzing.md). Python's standard library only.
"""
import math
import pathlib
import re
import struct
import sys

from mutate_cases import arguments, bytewise as byte_edits, load_dictionary

HERE = pathlib.Path(__file__).resolve().parent
CORPUS = HERE / "corpus"
FORMATS = ["stl_ascii", "stl_binary", "obj", "ply_ascii", "ply_le", "ply_be"]
AWKWARD = ["0", "-0", "-1", "-25", "1e-320", "1e400", "-1e400", "nan", "NaN", "inf", "-inf", "1e20", "2147483648",
           "4294967296", "-2147483649", "18446744073709551616", "3", "2", "1", "x", ""]


# ---------------------------------------------------------------------------------------------- reading the seeds
def parse_stl(data):
    if data[:5].lower() == b"solid" and b"facet" in data[:300]:
        nums = re.findall(rb"vertex\s+(\S+)\s+(\S+)\s+(\S+)", data)
        pts = [tuple(float(x) for x in n) for n in nums]
    else:
        n = struct.unpack_from("<I", data, 80)[0]
        if len(data) != 84 + 50 * n: return None
        pts = []
        for i in range(n):
            vals = struct.unpack_from("<12f", data, 84 + 50 * i)
            pts += [vals[3:6], vals[6:9], vals[9:12]]
    if len(pts) % 3: return None
    index, verts, faces = {}, [], []
    for i in range(0, len(pts), 3):
        tri = []
        for p in pts[i:i + 3]:
            if p not in index:
                index[p] = len(verts)
                verts.append(p)
            tri.append(index[p])
        faces.append(tuple(tri))
    return verts, faces


def parse_obj(data):
    verts, faces = [], []
    for line in data.decode("latin-1").splitlines():
        w = line.split()
        if not w: continue
        if w[0] == "v": verts.append(tuple(float(x) for x in w[1:4]))
        elif w[0] == "f":
            idx = [int(x.split("/")[0]) for x in w[1:]]
            idx = [i - 1 if i > 0 else len(verts) + i for i in idx]
            faces += [(idx[0], idx[k], idx[k + 1]) for k in range(1, len(idx) - 1)]
    return verts, faces


def parse_ply(data):
    end = data.find(b"end_header\n")
    if end < 0: return None
    header = data[:end].decode("latin-1").split("\n")
    fmt = header[1].split()[1]
    nv = nf = 0
    props = []
    for line in header:
        w = line.split()
        if w[:2] == ["element", "vertex"]: nv = int(w[2])
        if w[:2] == ["element", "face"]: nf = int(w[2])
        if w[:1] == ["property"] and w[1] != "list" and nf == 0: props.append(w[1])
    if props != ["float"] * 3 and props != ["double"] * 3: return None  # only the plain seeds
    body = data[end + len("end_header\n"):]
    verts, faces = [], []
    if fmt == "ascii":
        lines = body.decode("latin-1").split("\n")
        verts = [tuple(float(x) for x in lines[i].split()[:3]) for i in range(nv)]
        for i in range(nf):
            w = [int(x) for x in lines[nv + i].split()]
            faces += [(w[1], w[1 + k], w[2 + k]) for k in range(1, w[0] - 1)]
    else:
        e = "<" if fmt == "binary_little_endian" else ">"
        vf = e + ("3f" if props[0] == "float" else "3d")
        off = 0
        for _ in range(nv):
            verts.append(struct.unpack_from(vf, body, off))
            off += struct.calcsize(vf)
        for _ in range(nf):
            k = body[off]
            w = struct.unpack_from(e + f"{k}i", body, off + 1)
            off += 1 + 4 * k
            faces += [(w[0], w[j], w[j + 1]) for j in range(1, k - 1)]
    return verts, faces


def parse(path, data):
    try:
        return {".stl": parse_stl, ".obj": parse_obj, ".ply": parse_ply}.get(path.suffix, lambda d: None)(data)
    except (ValueError, IndexError, struct.error, UnicodeDecodeError):
        return None


# ---------------------------------------------------------------------------------------------- writing
def num(x):
    return "nan" if x != x else ("inf" if x == math.inf else "-inf" if x == -math.inf else repr(float(x)))


def write(fmt, verts, faces, lie):
    if fmt == "stl_ascii":
        out = ["solid fuzz"]
        for f in faces:
            out.append("facet normal 0 0 0\nouter loop")
            out += ["vertex " + " ".join(num(c) for c in verts[i]) for i in f]
            out.append("endloop\nendfacet")
        return ("\n".join(out) + "\nendsolid fuzz\n").encode()
    if fmt == "stl_binary":
        count = 0xFFFFFFFF if lie else len(faces)
        b = bytearray(b"fuzz binary stl".ljust(80, b" ") + struct.pack("<I", count))
        for f in faces:
            b += struct.pack("<3f", 0, 0, 0)
            for i in f: b += struct.pack("<3f", *[max(min(c, 3e38), -3e38) if c == c and abs(c) != math.inf else c
                                                  for c in verts[i]])
            b += b"\0\0"
        return bytes(b)
    if fmt == "obj":
        out = ["# fuzz"] + ["v " + " ".join(num(c) for c in v) for v in verts]
        for k, f in enumerate(faces):
            idx = [i + 1 for i in f]
            if lie and k == 0: idx[0] = len(verts) + 7 if lie == 1 else -(len(verts) + 3)
            out.append("f " + " ".join(str(i) for i in idx))
        return ("\n".join(out) + "\n").encode()
    nv = 2**31 if lie == 1 else len(verts)
    nf = 2**31 - 1 if lie == 2 else len(faces)
    kind = {"ply_ascii": "ascii", "ply_le": "binary_little_endian", "ply_be": "binary_big_endian"}[fmt]
    head = (f"ply\nformat {kind} 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\nproperty float z\n"
            f"element face {nf}\nproperty list uchar int vertex_indices\nend_header\n").encode()
    if kind == "ascii":
        body = "".join(" ".join(num(c) for c in v) + "\n" for v in verts)
        body += "".join("3 " + " ".join(str(i) for i in f) + "\n" for f in faces)
        return head + body.encode()
    e = "<" if kind == "binary_little_endian" else ">"
    b = bytearray()
    for v in verts: b += struct.pack(e + "3f", *[max(min(c, 3e38), -3e38) if c == c and abs(c) != math.inf else c for c in v])
    for f in faces: b += struct.pack(e + "B3i", 3, *f)
    return head + bytes(b)


# ---------------------------------------------------------------------------------------------- mutations
def geometric(rng, verts, faces):
    verts, faces = list(verts), list(faces)
    for _ in range(rng.randint(1, 3)):
        if not faces: break
        what = rng.randrange(14)
        if what == 0:  # NaN / inf / huge coordinates
            for _ in range(rng.randint(1, 3)):
                i = rng.randrange(len(verts))
                v = list(verts[i])
                v[rng.randrange(3)] = rng.choice([math.nan, math.inf, -math.inf, 1e300, -1e38, 1e-300])
                verts[i] = tuple(v)
        elif what == 1:  # swapped faces (turned over)
            for k in rng.sample(range(len(faces)), max(1, len(faces) // rng.choice([1, 2, 10, 1000]))):
                a, b, c = faces[k]
                faces[k] = (a, c, b)
        elif what == 2:  # degenerate triangles: a repeated corner, or three points on a line
            for _ in range(rng.randint(1, 5)):
                k = rng.randrange(len(faces))
                a, b, c = faces[k]
                if rng.random() < 0.5: faces[k] = (a, a, b) if rng.random() < 0.5 else (a, b, b)
                else:
                    verts.append(tuple((p + q) / 2 for p, q in zip(verts[a], verts[b])))
                    faces.append((a, b, len(verts) - 1))
        elif what == 3:  # duplicated triangles, same way round or reversed
            for k in rng.sample(range(len(faces)), min(len(faces), rng.randint(1, 20))):
                a, b, c = faces[k]
                faces.append((a, b, c) if rng.random() < 0.5 else (c, b, a))
        elif what == 4:  # non-manifold fin: a third triangle on an edge
            for _ in range(rng.randint(1, 3)):
                a, b, _c = faces[rng.randrange(len(faces))]
                m = [(p + q) / 2 for p, q in zip(verts[a], verts[b])]
                m[rng.randrange(3)] += rng.choice([-30.0, 5.0, 0.01, 200.0])
                verts.append(tuple(m))
                faces.append((a, b, len(verts) - 1))
        elif what == 5:  # holes
            for k in sorted(rng.sample(range(len(faces)), min(len(faces), rng.randint(1, 40))), reverse=True):
                del faces[k]
        elif what == 6:  # two skins: the surface again, shifted
            n = len(verts)
            d = rng.choice([0.0, 0.5, 15.0, 300.0])
            verts += [(x + d, y, z) for x, y, z in verts]
            faces += [(a + n, b + n, c + n) for a, b, c in faces]
        elif what == 7:  # unit confusion
            s = rng.choice([1000.0, 0.001, 25.4, 1 / 25.4, 1e6, 1e-6])
            verts = [tuple(c * s for c in v) for v in verts]
        elif what == 8:  # far away
            d = rng.choice([1e6, -1e9, 1e30])
            verts = [(x + d, y, z) for x, y, z in verts]
        elif what == 9:  # flattened (a planar soup), or squashed along one axis
            ax = rng.randrange(3)
            s = rng.choice([0.0, 1e-9, 0.05])
            verts = [tuple(c * s if j == ax else c for j, c in enumerate(v)) for v in verts]
        elif what == 10:  # shuffled faces
            rng.shuffle(faces)
        elif what == 11:  # one face, or none
            faces = faces[:rng.randint(0, 1)]
        elif what == 12:  # jitter: vertices moved so faces cross
            for i in rng.sample(range(len(verts)), min(len(verts), rng.randint(1, 30))):
                verts[i] = tuple(c + rng.uniform(-60, 60) for c in verts[i])
        else:  # every face fanned to one vertex (a spiky soup)
            k = rng.randrange(len(verts))
            for j in rng.sample(range(len(faces)), min(len(faces), rng.randint(1, 10))):
                a, b, _c = faces[j]
                faces[j] = (a, b, k)
    return verts, faces


def aaop(rng, text):
    lines = text.decode("latin-1").split("\n")
    for _ in range(rng.randint(1, 3)):
        what = rng.randrange(6)
        numeric = [i for i, l in enumerate(lines) if re.fullmatch(r"-?[0-9.]+", l.strip())]
        if what < 3 and numeric:  # an awkward value in place of a number (count, spacing, radius)
            lines[rng.choice(numeric)] = rng.choice(AWKWARD)
        elif what == 3 and numeric:  # unit confusion: every radius and height in m, or in µm
            s = rng.choice([0.001, 1000.0, 25.4])
            for i in numeric[rng.randrange(len(numeric)):]:
                lines[i] = repr(float(lines[i]) * s)
        elif what == 4:  # a line dropped (a spoke or a slice short)
            if lines: del lines[rng.randrange(len(lines))]
        else:  # cut
            lines = lines[:rng.randrange(len(lines) + 1)]
    return "\n".join(lines).encode()


def bytewise(rng, data, other, words):
    """Sometimes a number (a count, an index, a coordinate) made huge or awkward, or a binary STL's
    count changed; then mutate_cases.py's byte edits."""
    data = bytearray(data)
    if rng.random() < 0.3:
        nums = list(re.finditer(rb"-?[0-9]+(\.[0-9]*)?", bytes(data)))
        if nums:
            m = rng.choice(nums)
            data[m.start():m.end()] = rng.choice(AWKWARD).encode()
        elif len(data) >= 84:
            data[80:84] = struct.pack("<I", rng.choice([0, 1, 0xFFFFFFFF, 0x7FFFFFFF, 3]))
    return byte_edits(rng, bytes(data), other, words)


def main(argv):
    if (args := arguments(argv, __doc__)) is None:
        return 2
    out, count, rng = args
    paths = [p for d in ("stl", "obj", "ply") for p in sorted((CORPUS / d).iterdir()) if p.is_file()]
    paths += sorted((CORPUS / "limb").glob("tiny_limb*"))
    seeds = [(p, p.read_bytes()) for p in paths]
    # Seeds that parse to a soup with every index in range (the edge cases that do not are byte-mutated).
    parsed = [(p, m) for p, d in seeds for m in [parse(p, d)]
              if m and m[1] and all(0 <= i < len(m[0]) for f in m[1] for i in f)]
    # The limb seeds are the ones that reach the mesher: give them most of the geometric draws.
    limbs = [(p, m) for p, m in parsed if "limb" in p.name]
    aops = [(p, d) for p, d in seeds if p.suffix == ".aop"]
    words = load_dictionary("mesh.dict")
    out.mkdir(parents=True, exist_ok=True)
    ext = {"stl_ascii": "stl", "stl_binary": "stl", "obj": "obj", "ply_ascii": "ply", "ply_le": "ply", "ply_be": "ply"}
    for i in range(count):
        what = rng.random()
        if what < 0.5:
            p, (v, f) = rng.choice(limbs) if rng.random() < 0.8 else rng.choice(parsed)
            v, f = geometric(rng, v, f)
            fmt = rng.choice(FORMATS)
            lie = rng.choice([1, 2]) if rng.random() < 0.08 else 0
            name, data = f"mesh_{i:04d}.{ext[fmt]}", write(fmt, v, f, lie)
        elif what < 0.67:
            p, d = rng.choice(aops)
            name, data = f"mesh_{i:04d}.aop", aaop(rng, d)
        else:
            p, d = rng.choice(seeds)
            name, data = f"mesh_{i:04d}{p.suffix}", bytewise(rng, d, rng.choice(seeds)[1], words)
        (out / name).write_bytes(data)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
