#!/usr/bin/env python3
"""Issue 15 regression tests, through the horizon program as a user runs it:
the default LOD is cdlod at 1 px (the seed's modes one --lod away), ...

usage: test_polish.py HORIZON DATA TMPDIR"""
import json, os, re, subprocess, sys

HZ, DATA, TMP = sys.argv[1], sys.argv[2], sys.argv[3]
os.makedirs(TMP, exist_ok=True)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from clitest import ok, bad, check, run_hz, finish  # noqa: E402,F401


def run(args, timeout=300):
    return run_hz(HZ, args, timeout)


def tmp(name):
    return os.path.join(TMP, name)


def render_json(args, quiet=True):
    """render at 320x180 with --json (and --quiet unless quiet=False, to read
    the notes on stderr): (the JSON or None, stderr)"""
    q = ["--quiet"] if quiet else []
    rc, out, err = run(["render"] + q + ["--width", "320", "--height", "180", "--json"] + args)
    if rc != 0:
        return None, err
    try:
        return json.loads(out), err
    except ValueError as e:
        return None, "bad JSON: %s: %s" % (e, out[:300])


# ---------------------------------------------------------------------------
# 1. The default LOD is cdlod at 1 px in render and bench; --lod picks a seed mode.
j, err = render_json(["--generate", "perlin", "--size", "257", "--out", tmp("default.png")])
check(j and j["lod_mode"] == "cdlod" and j["pixel_error"] == 1, "render: default LOD is cdlod, 1 px", j or err)
j, err = render_json(["--generate", "perlin", "--size", "257", "--lod", "quadtree", "--out", tmp("q.png")])
check(j and j["lod_mode"] == "quadtree" and j["pixel_error"] == 0 and j["lod_c"] == 25,
      "render --lod quadtree: the seed's mode on C and C2", j or err)
rc, out, err = run(["render", "--width", "160", "--height", "90", "--generate", "perlin", "--size", "257",
                    "--lod-c", "40", "--out", tmp("c.png")])
check(rc == 0 and "--lod quadtree" in err, "render: --lod-c with cdlod says it does not apply", err)
rc, out, err = run(["bench", "--quiet", "--generate", "perlin", "--size", "257", "--frames", "2", "--width", "160",
                    "--height", "90", "--reference", "off", "--metrics", "off", "--json", tmp("b.json")])
try:
    b = json.load(open(tmp("b.json"))) if rc == 0 else None
except ValueError as e:
    b = None
    err = str(e)
check(b and b["lod_mode"] == "cdlod", "bench: default LOD is cdlod", b and b["lod_mode"] or err)

# ---------------------------------------------------------------------------
# 2. Normalised and offset data; straight-down views; a default camera that
#    shows the place.
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import pngstat  # noqa: E402

MB = os.path.join(DATA, "alps-montblanc_norm16.png")
if os.path.exists(MB):
    rc, out, err = run(["render", "--width", "160", "--height", "90", "--dem", MB, "--out", tmp("mb0.png")])
    check(rc == 0 and "--height-range" in err, "a normalised PNG: the note names --height-range", err[-300:])
    j, err = render_json(["--dem", MB, "--height-range", "454,4810", "--spacing", "92.7", "--out", tmp("mb.png")])
    check(j and j["terrain_in_view"] and 4810 < j["camera"][1] < 12000,
          "--height-range 454,4810: Mont Blanc at its height, in view", j and j["camera"] or err)
    px = pngstat.pixels(tmp("mb.png"))
    check(sum(map(pngstat.is_sky, px)) < 0.8 * len(px), "--height-range: the image shows terrain")
    j2, err = render_json(["--dem", MB, "--height-range", "454,4810", "--height-offset", "-454", "--spacing", "92.7",
                           "--out", tmp("mb2.png")])
    check(j and j2 and abs((j["camera"][1] - j2["camera"][1]) - 454) < 1.0,
          "--height-offset -454 lowers the terrain (and the default camera) by 454 m",
          (j and j["camera"], j2 and j2["camera"]))
    for args, what in [(["--height-range", "5,5"], "MIN below MAX"), (["--height-range", "1"], "MIN,MAX"),
                       (["--height-offset", "1e6"], "in \[-1e5, 1e5\]")]:
        rc, out, err = run(["render", "--dem", MB] + args + ["--out", tmp("bad.png")])
        import re
        check(rc == 2 and re.search(what, err), "refused: %s" % " ".join(args), err)
    rc, out, err = run(["render", "--generate", "perlin", "--size", "257", "--height-range", "0,100", "--out",
                        tmp("bad.png")])
    check(rc != 0 and "generated" in err, "--height-range on a generated terrain is refused", err)
else:
    bad("missing " + MB)

N44 = os.path.join(DATA, "N44W072.hgt")
for pitch in ["-90", "-89.9"]:
    j, err = render_json(["--dem", N44, "--camera", "40000,5000,50000,0," + pitch, "--effects", "none",
                          "--out", tmp("down%s.png" % pitch)])
    px = pngstat.pixels(tmp("down%s.png" % pitch)) if j else []
    check(j and j["terrain_in_view"] and pngstat.distinct(px) > 100 and
          sum(map(pngstat.is_sky, px)) < 0.05 * len(px),
          "straight down (pitch %s) 50 km from the origin renders terrain" % pitch,
          j and (pngstat.distinct(px), sum(map(pngstat.is_sky, px))) or err)

# The default camera frames St Helens' crater rim: the highest ground is in
# front, and the image is mostly terrain below the horizon with sky above.
SH = os.path.join(DATA, "sthelens_10m_dm16.png")
j, err = render_json(["--dem", SH, "--out", tmp("sh.png")])
if j:
    top = pngstat.pixels(tmp("sh.png"), 0.0, 0.15)
    low = pngstat.pixels(tmp("sh.png"), 0.6, 1.0)
    check(sum(map(pngstat.is_sky, top)) > 0.5 * len(top) and sum(map(pngstat.is_sky, low)) < 0.02 * len(low),
          "St Helens default view: sky above, the mountain below", j["camera"])
    check(j["camera"][4] < -3, "St Helens default view looks down at the summit", j["camera"])
else:
    bad("St Helens default render: " + err)

# ---------------------------------------------------------------------------
# 3. Real places look like themselves: ground colour from absolute altitude,
#    slope and latitude; no trees or lakes in a desert; no invented sea.
SAHARA = os.path.join(DATA, "sahara_3as_ft16.png")
SAHARA_TIF = tmp("sahara_georef.tif")
# The Sahara tile (feet, 3 arc-seconds, 648^2) placed where it could lie: 25 N, 9 E.
p = subprocess.run(["gdal_translate", "-q", "-of", "GTiff", "-a_srs", "EPSG:4326", "-a_ullr", "9.0", "25.54", "9.54",
                    "25.0", "-ot", "Float32", "-scale", "0", "65535", "0", str(65535 * 0.3048), SAHARA, SAHARA_TIF],
                   capture_output=True)
check(p.returncode == 0, "gdal_translate georeferences the Sahara tile", p.stderr)


def terrain_hue(png):
    px = [q for q in pngstat.pixels(png, 0.45, 1.0) if not pngstat.is_sky(q)]
    return pngstat.mean_hue(px) + (len(px),)


j, err = render_json(["--dem", SAHARA_TIF, "--out", tmp("sahara.png")])
if j:
    hue, green, n = terrain_hue(tmp("sahara.png"))
    check(n > 1000 and green < 0.02 and (hue < 55 or hue > 330),
          "the georeferenced Sahara is not green (mean hue %.0f deg, %.1f %% green pixels)" % (hue, 100 * green))
    check(j["climate"] == "arid" and j["climate_from_place"] and j["aridity"] >= 0.9,
          "the Sahara's climate comes from its place", j["climate"])
    check(j["trees"] == 0 and j["billboards"] == 0, "no trees in the desert", (j["trees"], j["billboards"]))
    check(j["water_level"] is None, "no lakes in the desert", j["water_level"])
else:
    bad("Sahara render: " + err)
# Without a georeference horizon cannot know: temperate by default (green),
# desert with --climate arid.
j, err = render_json(["--dem", SAHARA, "--out", tmp("sahara_plain.png")])
hue, green, n = terrain_hue(tmp("sahara_plain.png")) if j else (0, 0, 0)
check(j and green > 0.3 and not j["climate_from_place"],
      "a DEM without a georeference: temperate default (green, %.0f %%)" % (100 * green), err)
j, err = render_json(["--dem", SAHARA, "--climate", "arid", "--out", tmp("sahara_arid.png")])
hue, green, n = terrain_hue(tmp("sahara_arid.png")) if j else (0, 1, 0)
check(j and green < 0.02 and j["trees"] == 0, "--climate arid: the same tile is a desert (hue %.0f)" % hue, err)

# Snow by absolute height and latitude: Mount Washington (1917 m, 44 N) has
# no permanent snow; the old relative rule capped the top of every map.
j, err = render_json(["--dem", N44, "--effects", "none", "--out", tmp("n44.png")])
if j:
    px = pngstat.pixels(tmp("n44.png"), 0.55, 1.0)
    white = sum(1 for r, g, b in px if min(r, g, b) > 180) / len(px)
    check(white < 0.002 and j["snow_line"] > 2500, "no snow on Mount Washington (%.2f %% white)" % (100 * white),
          j["snow_line"])
else:
    bad("N44W072 render: " + err)
# ... but the Andes at 33 S (Aconcagua, 6961 m) carry snow above ~4800 m.
j, err = render_json(["--dem", os.path.join(DATA, "S33W071.tif"), "--effects", "none", "--out", tmp("s33.png")])
if j:
    px = pngstat.pixels(tmp("s33.png"), 0.4, 1.0)
    white = sum(1 for r, g, b in px if min(r, g, b) > 180) / len(px)
    check(white > 0.02 and 4000 < j["snow_line"] < 6000, "snow on the high Andes (%.1f %% white)" % (100 * white),
          j["snow_line"])

# The automatic water level does not drown land: S46W066's sea is at 0 m.
S46 = os.path.join(DATA, "S46W066.hgt.gz")
if os.path.exists(S46):
    j, err = render_json(["--dem", S46, "--out", tmp("s46.png")], quiet=False)
    check(j and j["water_level"] is not None and 0 <= j["water_level"] <= 0.5,
          "S46W066: the sea just above 0 m, not a 1 m sea over the land", j and j["water_level"] or err)
    # Reprojected to 3759x5231 it is kept whole on 8193^2, 71 % padding: the
    # note names the spacing that fits 4097^2, and that spacing does.
    m = re.search(r"(\d+) % padding: --spacing ([0-9.]+) fits it in 4097x4097", err)
    check(j and j["heightmap_size"] == 8193 and m and int(m.group(1)) > 50,
          "S46W066 on a mostly padded 8193^2 grid: the note gives the spacing for 4097^2", err[-400:])
    if m:
        j, err = render_json(["--dem", S46, "--spacing", m.group(2), "--out", tmp("s46s.png")], quiet=False)
        check(j and j["heightmap_size"] == 4097 and 4000 < max(j["data_size"]) <= 4097 and "% padding" not in err,
              "S46W066 at --spacing %s: every sample on 4097^2, no padding note" % m.group(2),
              j and (j["heightmap_size"], j["data_size"]) or err[-400:])
else:
    bad("missing " + S46)
# ... nor invents lakes on a real place: Heidelberg's lowest 4 % is the Rhine plain, farmland.
HD = os.path.join(DATA, "heidelberg_dem_hd_utm32n_25m_float32.tif")
j, err = render_json(["--dem", HD, "--out", tmp("hd_water.png")])
check(j and j["water_level"] is None and j["climate_from_place"] and j["reflections"] == 0,
      "heidelberg: no lakes invented over the Rhine plain", j and (j["water_level"], j["reflections"]) or err)

# A camera far above the height fog (30 km up) with every effect on: the
# terrain is hazy, never black (the height-fog integral overflowed to NaN).
j, err = render_json(["--generate", "perlin", "--size", "1025", "--camera", "5120,30000,-2000,180,-55",
                      "--out", tmp("high.png")])
px = pngstat.pixels(tmp("high.png"), 0.7, 1.0) if j else []
dark = sum(1 for r, g, b in px if r + g + b < 60)
check(j and j["terrain_in_view"] and px and dark < 0.01 * len(px),
      "a view from 30 km with effects shows terrain, not black (%d dark of %d)" % (dark, len(px)), j or err)

# A small map (2.5 km) seen from its default camera: the default fog is a
# clear day's haze, not 3 / view distance (which hid most of a town seen from
# 3 km). Against no fog at all, the ground changes a little; the old default
# density changes it several times more.
def ground_diff(a, b):
    pa, pb = pngstat.pixels(a, 0.5, 1.0), pngstat.pixels(b, 0.5, 1.0)
    return sum(abs(p[i] - q[i]) for p, q in zip(pa, pb) for i in range(3)) / (3.0 * max(len(pa), 1))


small = ["--generate", "perlin", "--size", "257", "--effects", "sky,fog"]
j, err = render_json(small + ["--out", tmp("fog_default.png")])
j0, err0 = render_json(small + ["--fog", "off", "--out", tmp("fog_off.png")])
j3 = None
if j and j0:
    j3, err3 = render_json(small + ["--fog", "%.8f" % (3.0 / j["far"]), "--out", tmp("fog_3far.png")])
if j and j0 and j3:
    light, thick = ground_diff(tmp("fog_default.png"), tmp("fog_off.png")), ground_diff(tmp("fog_3far.png"),
                                                                                      tmp("fog_off.png"))
    check(light < 10 and light < 0.4 * thick,
          "a 2.5 km map is not lost in the default fog: ground %.1f from no fog, %.1f at 3 / view distance"
          % (light, thick))
else:
    bad("fog renders failed: %s" % (err if not j else err0 if not j0 else "3/far"))

# ---------------------------------------------------------------------------
# 4. JSON written by a JSON library: every command's JSON parses strictly
#    (no duplicate keys, no NaN), whatever the file names.
import struct, zlib  # noqa: E402


def strict(text):
    def pairs(p):
        keys = [k for k, _ in p]
        dup = sorted(set(k for k in keys if keys.count(k) > 1))
        if dup:
            raise ValueError("duplicate keys %s" % dup)
        return dict(p)

    def no_const(c):
        raise ValueError("not JSON: " + c)
    return json.loads(text, object_pairs_hook=pairs, parse_constant=no_const)


def png16(path, w, h):
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    rows = b"".join(b"\0" + b"".join(struct.pack(">H", (3000 + 40 * i + 25 * j + (i * j) % 97) & 0xffff)
                                     for i in range(w)) for j in range(h))
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 16, 0, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(rows, 9)) + chunk(b"IEND", b""))


# A quote, a backslash, a newline, a control character, accents and a byte
# that is not UTF-8 (0xff, through surrogateescape).
HOSTILE = tmp('quote" back\\slash\nnewline \x01 \xe9t\xe9 \udcff.png')
try:
    png16(HOSTILE, 65, 65)
    hostile_ok = True
except OSError as e:
    hostile_ok = False
    bad("cannot create a file with a hostile name: %s" % e)


def json_case(what, args, out_file=None, env_cmd=None):
    cmd = ([] if env_cmd is None else env_cmd) + [HZ] + args
    p = subprocess.run(cmd, capture_output=True, timeout=600)
    try:
        text = open(out_file, encoding="utf-8", errors="strict").read() if out_file and p.returncode == 0 \
            else p.stdout.decode("utf-8", "strict")
        if p.returncode != 0:
            raise ValueError("exit %d: %s" % (p.returncode, p.stderr.decode("utf-8", "replace")[-300:]))
        j = strict(text)
        ok("strict JSON: " + what)
        return j
    except ValueError as e:
        bad("strict JSON: %s: %s" % (what, e))
        return None


if hostile_ok:
    hostile_out = tmp('out "q" \\ \n.png')
    j = json_case("render with a hostile DEM and output name",
                  ["render", "--quiet", "--width", "160", "--height", "90", "--dem", HOSTILE, "--spacing", "10",
                   "--out", hostile_out, "--json"])
    check(j and j["out"] == hostile_out and j["terrain"] == os.path.basename(HOSTILE).encode(
        "utf-8", "surrogateescape").decode("utf-8", "replace"),
        "render JSON: the names come back as they were (bad UTF-8 as U+FFFD)", j and (j["out"], j["terrain"]))
    json_case("info --json with a hostile name", ["info", "--json", HOSTILE])
    bj = tmp('bench "b".json')
    j = json_case("bench --json with a hostile DEM name",
                  ["bench", "--quiet", "--dem", HOSTILE, "--spacing", "10", "--frames", "2", "--width", "160",
                   "--height", "90", "--json", bj], out_file=bj)
    check(j and len(j["per_frame"]) == 2, "bench JSON per_frame rows", j and j.keys())
    json_case("bench --lod list (compare)",
              ["bench", "--quiet", "--generate", "perlin", "--size", "257", "--frames", "2", "--width", "160",
               "--height", "90", "--lod", "quadtree,cdlod", "--reference", "off", "--json", tmp("cmp.json")],
              out_file=tmp("cmp.json"))
    json_case("bench --effect-costs",
              ["bench", "--quiet", "--generate", "perlin", "--size", "257", "--frames", "1", "--width", "160",
               "--height", "90", "--effect-costs", tmp("costs.json")], out_file=tmp("costs.json"))
j = json_case("render --forest --json (had nodes_culled twice)",
              ["render", "--quiet", "--generate", "perlin", "--size", "257", "--width", "160", "--height", "90",
               "--forest", "10", "--forest-leaves", "2000", "--tree-cache", tmp("trees"), "--out", tmp("f.png"),
               "--json"])
check(j and "forest_nodes_culled" in j and "nodes_culled" in j, "render --forest: terrain and forest culled nodes",
      j and sorted(j.keys()))
json_case("tree --json", ["tree", "--quiet", "--species", "birch", "--leaves", "1000", "--no-rank", "--no-hull",
                          "--json"])
XVFB = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts", "with-xvfb.sh")
if hostile_ok:
    json_case("view --json with a hostile DEM name",
              ["view", "--quiet", "--dem", HOSTILE, "--spacing", "10", "--frames", "2", "--width", "320", "--height",
               "180", "--json"], env_cmd=["bash", XVFB])

# ---------------------------------------------------------------------------
# 5. The command line behaves like a Unix tool (getopt_long): --opt=value,
#    suggestions for typos, --version, per-command --help; bench --plot
#    checks for gnuplot before the run.
a, _ = render_json(["--generate", "perlin", "--size", "257", "--camera", "1000,900,1000,45,-20",
                    "--out", tmp("eq1.png")])
b, err = render_json(["--generate=perlin", "--size=257", "--camera=1000,900,1000,45,-20", "--out=" + tmp("eq2.png")])
check(a and b and a["triangles"] == b["triangles"] and a["camera"] == b["camera"] and b["heightmap_size"] == 257,
      "--opt=value reads like --opt value", err)
for cmd, typo, want in [("render", "--pixel-eror", "--pixel-error"), ("render", "--lod-cc", "--lod-c"),
                        ("bench", "--frmes", "--frames"), ("view", "--walk-sped", "--walk-speed"),
                        ("tree", "--specis", "--species"), ("info", "--jsno", "--json")]:
    rc, out, err = run([cmd, typo, "1"])
    check(rc == 2 and "did you mean %s?" % want in err, "%s %s suggests %s" % (cmd, typo, want), err.strip())
rc, out, err = run(["render", "--frobnicate"])
check(rc == 2 and "unknown option '--frobnicate'" in err and "did you mean" not in err,
      "an option far from every name gets no suggestion", err.strip())
rc, out, err = run(["render", "--json=yes"])
check(rc == 2 and "takes no value" in err, "a flag given a value is refused", err.strip())
rc, out, err = run(["render", "--dem"])
check(rc == 2 and "--dem needs a value" in err, "a missing value is named", err.strip())
rc, out, err = run(["--version"])
check(rc == 0 and out.startswith("horizon ") and len(out.split()) == 2, "horizon --version", out)
rc, out, err = run(["render", "--version"])
check(rc == 0 and out.startswith("horizon "), "horizon render --version", out)
for cmd in ["render", "bench", "view", "tree", "info"]:
    rc, out, err = run([cmd, "--help"])
    check(rc == 0 and ("usage: horizon " + cmd) in (out + err), "horizon %s --help" % cmd, (rc, err[:80]))
env = dict(os.environ, PATH="/nonexistent")
import time  # noqa: E402
t0 = time.time()
p = subprocess.run([os.path.abspath(HZ), "bench", "--quiet", "--generate", "perlin", "--size", "257", "--frames",
                    "200", "--plot", tmp("plot.png")], capture_output=True, timeout=60, env=env)
err = p.stderr.decode("utf-8", "replace")
check(p.returncode == 2 and "gnuplot" in err and time.time() - t0 < 5,
      "bench --plot without gnuplot stops before the run", err.strip())

# Config files are read by libinih; every error names the file and the line.
for name, text, want in [("nokey.conf", "lod-c = 40\n\nlod-c2 3\n", ":3: expected 'key = value'"),
                         ("flag.conf", "# a comment\nwireframe = maybe\n", ":2: 'wireframe' takes true or false"),
                         ("section.conf", "lod-c = 40  # C\n[graphics]\nlod-c2 = 3\n", ":3: sections"),
                         ("binary.conf", "lod-c = 4\x01\n", ":1: byte 0x01"),
                         ("nest.conf", "config = other.conf\n", ":1: config files do not nest")]:
    with open(tmp(name), "w") as f:
        f.write(text)
    env = dict(os.environ)
    env.pop("DISPLAY", None)  # the config is read before any window opens
    p = subprocess.run([HZ, "view", "--quiet", "--config", tmp(name), "--frames", "1"], capture_output=True,
                       timeout=60, env=env)
    err = p.stderr.decode("utf-8", "replace")
    check(p.returncode == 2 and (tmp(name) + want) in err, "config %s: %s" % (name, want), err.strip())

finish()
