#!/usr/bin/env python3
"""Issue 15 regression tests, through the horizon program as a user runs it:
the default LOD is cdlod at 1 px (the seed's modes one --lod away), ...

usage: test_polish.py HORIZON DATA TMPDIR"""
import json, os, subprocess, sys

HZ, DATA, TMP = sys.argv[1], sys.argv[2], sys.argv[3]
os.makedirs(TMP, exist_ok=True)
fails, passes = 0, 0


def ok(msg):
    global passes
    passes += 1
    print("ok   " + msg)


def bad(msg):
    global fails
    fails += 1
    print("FAIL " + msg)


def check(cond, msg, detail=""):
    if cond:
        ok(msg)
    else:
        bad(msg + (": " + str(detail) if detail else ""))


def run(args, timeout=300):
    p = subprocess.run([HZ] + args, capture_output=True, timeout=timeout)
    return p.returncode, p.stdout.decode("utf-8", "replace"), p.stderr.decode("utf-8", "replace")


def tmp(name):
    return os.path.join(TMP, name)


def render_json(args):
    rc, out, err = run(["render", "--quiet", "--width", "320", "--height", "180", "--json"] + args)
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

print("%d passed, %d failed" % (passes, fails))
sys.exit(1 if fails else 0)
