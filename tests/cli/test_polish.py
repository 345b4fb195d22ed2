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

print("%d passed, %d failed" % (passes, fails))
sys.exit(1 if fails else 0)
