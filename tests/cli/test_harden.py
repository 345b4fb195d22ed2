#!/usr/bin/env python3
"""Issue 14 regression tests, through the horizon program as a user runs it:
every documented numeric bound is accepted at both ends (and refused just
outside), no output overwrites an input (the input stays byte-identical),
the 298-byte file that asked for 17 GB is refused within 1 s under 200 MB,
limits are checked before long work, and the silent acceptances now have
clear messages.

usage: test_harden.py HORIZON TMPDIR"""
import gzip, os, re, resource, shutil, struct, subprocess, sys, time, zlib

HZ, TMP = sys.argv[1], sys.argv[2]
os.makedirs(TMP, exist_ok=True)
NOPE = os.path.join(TMP, "nonexistent", "none.png")  # fails fast after parsing
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from clitest import ok, bad, check, run_hz, finish  # noqa: E402,F401

def run(args, timeout=120):
    p = subprocess.run([HZ] + args, capture_output=True, timeout=timeout)
    return p.returncode, p.stderr.decode("utf-8", "replace"), p.stderr


def tmp(name):
    return os.path.join(TMP, name)


def png16(path, w, h, v=lambda i, j: 1000 + 7 * i + 11 * j):
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    rows = b"".join(b"\0" + b"".join(struct.pack(">H", v(i, j) & 0xffff) for i in range(w)) for j in range(h))
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 16, 0, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(rows, 9)) + chunk(b"IEND", b""))


# ---------------------------------------------------------------------------
# 1. Every documented bound, at both ends.
# The ranges come from the parsers' own messages ("expected ... in [lo, hi]"),
# for every option each command's --help lists, so a new option is covered
# the day it is added. A value is accepted when the run goes past option
# parsing (it then fails on the missing input, not with "invalid value").
# (tree: --rank-res is only taken with --rank-tree 0, node by node.)
BASE = {"render": ["--dem", NOPE], "bench": ["--dem", NOPE], "view": ["--dem", NOPE],
        "tree": ["--in", NOPE + ".hzt", "--rank-tree", "0"]}


def accepted(cmd, opt, val):
    # Past the option parser: it fails later, on the missing input (or, for
    # tree, on the choice of source), never with "invalid value".
    rc, err, _ = run([cmd] + BASE[cmd] + [opt, val])
    return rc != 0 and "invalid value" not in err and ("nonexistent" in err or "give one source" in err), err.strip()


def refused(cmd, opt, val):
    rc, err, _ = run([cmd] + BASE[cmd] + [opt, val])
    return rc == 2 and "invalid value" in err, err.strip()


def num(s):
    try:
        return float(s)
    except ValueError:
        return None


RANGE = re.compile(r"\[(-?[0-9][0-9.e+-]*[A-Za-z]?), (-?[0-9][0-9.e+-]*[A-Za-z]?)\]")
tested = set()
COMPOUND = {"--camera", "--forest-at", "--rate-weights", "--sun", "--wind", "--raw-size", "--height-range"}
for cmd in ["render", "bench", "view", "tree"]:
    rc, helptext, _ = run([cmd, "--help"])
    opts = sorted(set(re.findall(r"(?m)(?:^|\s)(--[a-z0-9][a-z0-9-]*)", helptext)))
    for opt in opts:
        rc, err, _ = run([cmd] + BASE[cmd] + [opt, "x"])
        m = re.search(r"invalid value 'x' for " + re.escape(opt) + r": expected (.*)", err)
        if not m:
            continue
        ranges = RANGE.findall(m.group(1))
        if len(ranges) != 1 or opt in COMPOUND:
            continue  # compound values (X,Y,Z,...): below
        lo, hi = ranges[0]
        for end in (lo, hi):
            good, why = accepted(cmd, opt, end)
            (ok if good else bad)("%s %s %s (documented bound %s) accepted%s" %
                                  (cmd, opt, end, m.group(1), "" if good else ": " + why))
        a, b = num(lo), num(hi)
        if a is not None and b is not None:
            whole = a == int(a) and b == int(b) and "." not in lo + hi and "e" not in lo + hi
            outside = [str(int(a) - 1), str(int(b) + 1)] if whole else \
                      ["%.9g" % (a - 1e-3 * max(1.0, abs(a))), "%.9g" % (b + 1e-3 * max(1.0, abs(b)))]
            for v in outside:
                good, why = refused(cmd, opt, v)
                (ok if good else bad)("%s %s %s (outside %s) refused%s" % (cmd, opt, v, ranges[0], "" if good else ": " + why))
        tested.add((cmd, opt))

# The list must be among them (so the extraction cannot miss them).
for cmd, opt in [("render", "--morph-start"), ("render", "--spacing"), ("render", "--amplitude"),
                 ("render", "--bidir-distance"), ("render", "--blur"), ("render", "--bloom"), ("render", "--gamma"),
                 ("bench", "--fps"), ("view", "--speed"), ("view", "--mouse-sens"), ("render", "--max-memory")]:
    ((ok if (cmd, opt) in tested else bad))("%s %s bounds tested" % (cmd, opt))
for cmd, opt, val in [("render", "--morph-start", "0.8"), ("render", "--morph-start", "0.98"),
                      ("render", "--spacing", "0.001"), ("render", "--amplitude", "0.001"),
                      ("render", "--bidir-distance", "0.001"), ("render", "--blur", "0.001"),
                      ("render", "--bloom", "0.001"), ("render", "--gamma", "0.1"), ("bench", "--fps", "0.1"),
                      ("view", "--speed", "0.1"), ("view", "--mouse-sens", "0.001")]:
    good, why = accepted(cmd, opt, val)
    (ok if good else bad)("issue list: %s %s %s accepted%s" % (cmd, opt, val, "" if good else ": " + why))

# Compound values, every component at both ends.
for opt, vals, outs in [("--camera", ["-1e7,-1e7,-1e7,-1e7,-1e7", "1e7,1e7,1e7,1e7,1e7"], ["1e7,0,0,0,10000001"]),
                        ("--sun", ["-360,-90", "720,90"], ["-361,0", "0,90.01"]),
                        ("--wind", ["0,-360", "100,720"], ["100.1,0", "0,721"]),
                        ("--forest-at", ["-1e7,-1e7", "1e7,1e7"], ["1.1e7,0"]),
                        ("--rate-weights", ["0,0,0,0,0", "10,10,10,10,10"], ["0,0,0,0,10.01"]),
                        ("--raw-size", ["2x2", "65537x65537", "2", "65537"], ["1x2", "2x65538"])]:
    for v in vals:
        good, why = accepted("render", opt, v)
        (ok if good else bad)("render %s %s accepted%s" % (opt, v, "" if good else ": " + why))
    for v in outs:
        good, why = refused("render", opt, v)
        (ok if good else bad)("render %s %s refused%s" % (opt, v, "" if good else ": " + why))
# Empty items are errors, not skipped.
for cmd, opt, v in [("render", "--camera", "1,,2,3,4,5"), ("render", "--camera", "1,2,3,4,5,"),
                    ("render", "--sun", ",30"), ("render", "--rate-weights", "1,1,,1,1,1"),
                    ("bench", "--lod", "quadtree,,cdlod"), ("bench", "--lod", "quadtree,")]:
    good, why = refused(cmd, opt, v)
    (ok if good else bad)("%s %s %s refused (empty item)%s" % (cmd, opt, v, "" if good else ": " + why))

# ---------------------------------------------------------------------------
# 2. No output overwrites an input; the input stays byte-identical.
png16(tmp("d.png"), 33, 33)
with open(tmp("p.csv"), "w") as f:
    f.write("0,10,500,10,45,-10\n1,20,500,20,45,-10\n")
here = os.path.dirname(os.path.abspath(__file__))
shutil.copy(os.path.join(here, "..", "..", "fuzz", "corpus", "hzt", "minimal_hull"), tmp("t.hzt"))
with open(tmp("s.txt"), "w") as f:
    f.write("0 key W down\n3 quit\n")
with open(tmp("x.obj"), "w") as f:
    f.write("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
with open(tmp("v.conf"), "w") as f:
    f.write("generate = perlin\nsize = 33\n")
os.makedirs(tmp("sub"), exist_ok=True)
if os.path.lexists(tmp("link.png")):
    os.unlink(tmp("link.png"))
os.symlink(tmp("d.png"), tmp("link.png"))
cases = [
    ("d.png", ["render", "--dem", tmp("d.png"), "--out", tmp("d.png")]),
    ("d.png", ["render", "--dem", tmp("d.png"), "--out", tmp("sub/../d.png")]),
    ("d.png", ["render", "--dem", tmp("link.png"), "--out", tmp("d.png")]),
    ("d.png", ["render", "--dem", tmp("d.png"), "--out", tmp("o.png"), "--dump-mesh", tmp("d.png")]),
    ("d.png", ["render", "--generate", "perlin", "--size", "33", "--colormap", tmp("d.png"), "--out", tmp("d.png")]),
    ("p.csv", ["bench", "--generate", "perlin", "--size", "33", "--path", tmp("p.csv"), "--json", tmp("p.csv")]),
    ("d.png", ["bench", "--dem", tmp("d.png"), "--effect-costs", tmp("d.png")]),
    ("d.png", ["bench", "--dem", tmp("d.png"), "--plot", tmp("d.png")]),
    ("t.hzt", ["tree", "--in", tmp("t.hzt"), "--preview", tmp("t.hzt")]),
    ("t.hzt", ["tree", "--in", tmp("t.hzt"), "--out", tmp("t.hzt")]),
    ("x.obj", ["tree", "--import", tmp("x.obj"), "--out", tmp("x.obj")]),
    ("s.txt", ["view", "--generate", "perlin", "--size", "33", "--script", tmp("s.txt"), "--screenshot", tmp("s.txt")]),
    ("v.conf", ["view", "--config", tmp("v.conf"), "--screenshot", tmp("v.conf")]),
    ("p.csv", ["view", "--generate", "perlin", "--size", "33", "--path", tmp("p.csv"), "--screenshot", tmp("p.csv")]),
]
for victim, args in cases:
    with open(tmp(victim), "rb") as f:
        before = f.read()
    rc, err, _ = run(args)
    with open(tmp(victim), "rb") as f:
        after = f.read()
    good = rc == 2 and "refusing to overwrite" in err and before == after
    (ok if good else bad)("%s: refused, %s byte-identical%s" % (" ".join(a.replace(TMP + "/", "") for a in args), victim,
                                                                "" if good else ": exit %d, %s" % (rc, err.strip())))
# A script's screenshot event onto an input.
with open(tmp("s2.txt"), "w") as f:
    f.write("0 screenshot %s\n1 quit\n" % tmp("s2.txt"))
with open(tmp("s2.txt"), "rb") as f:
    before = f.read()
rc, err, _ = run(["view", "--generate", "perlin", "--size", "33", "--script", tmp("s2.txt")])
with open(tmp("s2.txt"), "rb") as f:
    after = f.read()
(ok if rc == 2 and "refusing to overwrite" in err and before == after else bad)(
    "view script screenshot onto the script refused: exit %d, %s" % (rc, err.strip()))

# ---------------------------------------------------------------------------
# 3. The 298-byte file: refused within 1 s under 200 MB, naming the size and
# the option. Measured in a child of its own (ru_maxrss of the children).
MEASURE = r"""
import resource, subprocess, sys, time
t0 = time.time()
p = subprocess.run(sys.argv[1:], capture_output=True)
dt = time.time() - t0
rss = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0
print("%d %.3f %.1f" % (p.returncode, dt, rss))
sys.stderr.write(p.stderr.decode("utf-8", "replace"))
"""


def measured(args):
    p = subprocess.run([sys.executable, "-c", MEASURE, HZ] + args, capture_output=True, timeout=300)
    rc, dt, rss = p.stdout.decode().split()
    return int(rc), float(dt), float(rss), p.stderr.decode("utf-8", "replace").strip()


with open(tmp("wide.r16.gz"), "wb") as f:
    f.write(gzip.compress(bytes(65537 * 2 * 2), 9, mtime=0))
png16(tmp("wide.png"), 65537, 2, lambda i, j: 0)
for name, extra in [("wide.r16.gz", ["--raw-size", "65537x2"]), ("wide.r16.gz", ["--raw-size", "65537x2", "--fit", "pad"]),
                    ("wide.png", [])]:
    for budget in ([], ["--max-memory", "1G"]):
        rc, dt, rss, err = measured(["render", "--dem", tmp(name), "--out", tmp("w.png")] + extra + budget)
        good = rc == 1 and dt < 1.0 and rss < 200 and "--max-memory" in err and "65537x65537" in err
        (ok if good else bad)("%s (%d bytes) %s: refused in %.2f s, %.0f MB: %s" %
                              (name, os.path.getsize(tmp(name)), " ".join(extra + budget), dt, rss, err))

# 4. Limits before long work: --size 16385 fails fast (GPU texture buffer
# limit, or the memory budget), not after a minute and 1.6 GB.
rc, dt, rss, err = measured(["render", "--generate", "perlin", "--size", "16385", "--out", tmp("big.png")])
good = rc == 1 and dt < 5.0 and rss < 300 and ("GL_MAX_TEXTURE_BUFFER_SIZE" in err or "--max-memory" in err)
(ok if good else bad)("--size 16385 refused in %.2f s, %.0f MB: %s" % (dt, rss, err))
rc, dt, rss, err = measured(["render", "--generate", "perlin", "--size", "4097", "--max-memory", "64M", "--out", tmp("b.png")])
good = rc == 1 and dt < 2.0 and "--max-memory" in err and "4097x4097" in err
(ok if good else bad)("--size 4097 --max-memory 64M refused in %.2f s: %s" % (dt, err))

# Images sized by their header (colour map, textures) are checked too.
def chunk(t, d):
    return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
with open(tmp("bigcm.png"), "wb") as f:
    f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 16000, 16000, 8, 2, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(b"\0" * 100)) + chunk(b"IEND", b""))
rc, dt, rss, err = measured(["render", "--generate", "perlin", "--size", "33", "--colormap", tmp("bigcm.png"),
                             "--max-memory", "256M", "--out", tmp("c.png")])
good = rc == 1 and "16000x16000" in err and "--max-memory" in err and rss < 300
(ok if good else bad)("colour map 16000x16000 with --max-memory 256M refused in %.2f s, %.0f MB: %s" % (dt, rss, err))

# ---------------------------------------------------------------------------
# 5/6. Values out of range and silent acceptances.
with open(tmp("huge.csv"), "w") as f:
    f.write("0,0,100,0,0,0\n1,3e38,100,-3e38,0,0\n")
rc, err, _ = run(["bench", "--generate", "perlin", "--size", "33", "--path", tmp("huge.csv"), "--frames", "2"])
(ok if rc != 0 and "out of range" in err and "1e7" in err else bad)("path CSV with 3e38 refused: %s" % err.strip())
rc, err, _ = run(["view", "--config", TMP])
(ok if rc == 2 and "directory" in err else bad)("view --config DIR refused: %s" % err.strip())
rc, err, _ = run(["view", "--script", TMP, "--generate", "perlin", "--size", "33"])
(ok if rc == 2 and "directory" in err else bad)("view --script DIR refused: %s" % err.strip())
with open(tmp("bin.conf"), "wb") as f:
    f.write(b"lod-c = 3\n" + bytes(range(256)) + b"\x1b[31mred\n")
rc, err, raw = run(["view", "--config", tmp("bin.conf")])
clean = all(c in (9, 10) or 32 <= c < 127 for c in raw)
(ok if rc == 2 and "binary" in err and clean else bad)("binary config refused without raw bytes: %r" % raw[:200])
with open(tmp("esc.conf"), "wb") as f:
    f.write(b"\xff\xfe garbage line with no equals\n")
rc, err, raw = run(["view", "--config", tmp("esc.conf")])
clean = all(c in (9, 10) or 32 <= c < 127 for c in raw)
(ok if rc == 2 and clean and "\\xff" in err else bad)("non-ASCII config line quoted escaped: %r" % raw[:200])
rc, err, _ = run(["render", "--generate", "perlin", "--size", "33", "--textures", tmp("no_such_dir"), "--out", tmp("t.png")])
(ok if rc == 1 and "cannot open the textures folder" in err and "No such file" in err else bad)(
    "--textures missing folder: %s" % err.strip())
os.makedirs(tmp("tex"), exist_ok=True)
png16(tmp("tex/grass.png"), 1, 1)
rc, err, _ = run(["render", "--generate", "perlin", "--size", "33", "--textures", tmp("tex"), "--out", tmp("t.png")])
(ok if rc == 1 and "power-of-two side from 4 to 8192" in err and "1x1" in err else bad)(
    "--textures 1x1 ground texture: %s" % err.strip())
# A hull vertex at 1e30 (the CRC fixed, so the bound is what refuses it).
with open(tmp("t.hzt"), "rb") as f:
    t = bytearray(f.read())
nb, nn, nl, bv, bi, hv, hi = struct.unpack_from("<7I", t, 56)
hull_pos = 8 + 4 + 32 + 8 + 8 * 4 + 6 * 4 + 4 * 4 + 8 + 6 * 4 + nb * 56 + nn * 12 + nl * 36 + bv * 24 + bi * 4
struct.pack_into("<f", t, hull_pos, 1e30)
struct.pack_into("<I", t, len(t) - 4, zlib.crc32(bytes(t[:-4])) & 0xffffffff)
with open(tmp("hull1e30.hzt"), "wb") as f:
    f.write(t)
rc, err, _ = run(["tree", "--in", tmp("hull1e30.hzt"), "--no-rank", "--no-hull"])
(ok if rc == 1 and "hull vertex 0" in err else bad)("hull vertex at 1e30 refused: %s" % err.strip())

# ---------------------------------------------------------------------------
# 7. Hostile file names: a DEM named -x.png (after "--" for info, as a value
# for render) and one with spaces and non-ASCII letters; operands where none
# are taken are refused by name, not ignored.
dash, odd = tmp("-x.png"), tmp("a name ü.png")
png16(dash, 33, 33)
png16(odd, 33, 33)
os.chdir(TMP)  # so that "-x.png" is the bare word a user types
for args, want, what in [
        (["info", "--", "-x.png", odd], None, "info -- -x.png 'a name ü.png' reads both"),
        (["info", "-x.png"], "goes after --", "info -x.png says to put the file after --"),
        (["render", "--dem", "-x.png", "--width", "64", "--height", "64", "--out", "-x out.png"], None,
         "render --dem -x.png --out '-x out.png'"),
        (["render", "--dem", odd, "--width", "64", "--height", "64", "--out", tmp("ü out.png")], None,
         "render --dem 'a name ü.png'"),
        (["render", "--dem", odd, "--", "extra.png"], "unexpected argument 'extra.png' after --",
         "render -- extra.png is refused, not ignored"),
        (["render", "--dem", odd, "extra.png"], "unexpected argument 'extra.png'", "render extra.png is refused"),
        (["tree", "--species", "oak", "--", "x"], "unexpected argument 'x' after --", "tree -- x is refused")]:
    p = subprocess.run([HZ] + args + (["--quiet"] if args[0] == "render" and want is None else []),
                       capture_output=True, timeout=120)
    err = p.stderr.decode("utf-8", "replace")
    if want is None:
        good = p.returncode == 0 and (args[0] != "info" or p.stdout.decode("utf-8", "replace").count("driver") == 2)
    else:
        good = p.returncode == 2 and want in err
    (ok if good else bad)("%s: rc %d %s" % (what, p.returncode, err.strip()[:200]))
check(os.path.getsize("-x out.png") > 0 and os.path.getsize(tmp("ü out.png")) > 0, "both images written")

finish("test_harden")
