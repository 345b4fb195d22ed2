#!/usr/bin/env python3
"""Issue 17: terrain pyramids over HTTP, through the horizon program as a user
runs it, against a real nginx started here (127.0.0.1, a free port, a config,
pid and logs in TMPDIR; no root paths) and a faulty proxy in front of it.

- render over http is byte-identical to the local-file render (two cameras);
  nginx's log shows the reads shared a few kept-alive connections;
- a short bench flies over http; a --deterministic flight over http has every
  frame identical to the local-file flight (per-frame image hashes); info
  --verify checks every tile over http;
- disk cache: a second run fetches only the header; with nginx stopped it
  still renders identically (offline); a damaged entry is refused and
  fetched again; --disk-cache-mb bounds the folder (least recently used out);
- faults (proxy): 500, a connection dropped mid-body and a delay past
  --http-timeout on the first attempts of every read are retried and the
  image is still identical; a tile that always fails, and one whose bytes
  arrive corrupt (caught by its checksum), end as "drawn coarser" with a
  warning and exit 0; a server ignoring ranges is refused at once.

usage: test_http.py HORIZON TMPDIR"""
import json, os, shutil, struct, subprocess, sys, time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from http_fixtures import NGINX, Nginx, Proxy  # noqa: E402
from clitest import ok, bad, check, run_hz, finish  # noqa: E402,F401
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))
from xxh64 import xxh64  # noqa: E402

HZ, TMP = sys.argv[1], os.path.abspath(sys.argv[2])
shutil.rmtree(TMP, ignore_errors=True)
os.makedirs(TMP)
def tmp(*names):
    return os.path.join(TMP, *names)


def run(args, timeout=300):
    t0 = time.time()
    p = subprocess.run([HZ] + args, capture_output=True, timeout=timeout)
    return p.returncode, p.stdout.decode(), p.stderr.decode(), time.time() - t0


def run_json(args, what, timeout=300):
    rc, out, err, dt = run(args + ["--json"], timeout)
    try:
        j = json.loads(out) if rc == 0 else None
    except ValueError:
        j = None
    if j is None:
        bad("%s: exit %d, %s" % (what, rc, err.strip()[-400:]))
    return rc, j, err, dt


def same(a, b):
    return os.path.exists(a) and os.path.exists(b) and open(a, "rb").read() == open(b, "rb").read()


# ---------------------------------------------------------------- nginx
if not os.access(NGINX, os.X_OK):
    bad("nginx is not installed (scripts/deps.sh installs it)")
    sys.exit(1)

www = tmp("www")
os.makedirs(www)
rc, _, err, _ = run(["import", "--generate", "perlin", "--size", "1025", "--seed", "7", "--out",
                     os.path.join(www, "x.hzp"), "--quiet"])
if not check(rc == 0, "import a 1025 pyramid"):
    print(err)
    sys.exit(1)
HZP = os.path.join(www, "x.hzp")
data = open(HZP, "rb").read()
idx_off, idx_bytes = struct.unpack_from("<QQ", data, 144)
recs = [struct.unpack_from("<QIIQ", data, idx_off + 24 * k) for k in range((idx_bytes - 8) // 24)]
# level 0: 4 x 4 tiles, level 1: 2 x 2 (records 16..19)
LEVEL1 = {r[0] for r in recs[16:20]}


# ---------------------------------------------------------------- tests
CAMS = [[], ["--camera", "2500,900,2500,135,-12"]]  # default (above the centre), and low across the map
ng = Nginx(www, tmp("nginx"))
try:
    # 1. local vs http, byte for byte
    local = []
    for k, cam in enumerate(CAMS):
        out = tmp("local%d.png" % k)
        rc, j, err, _ = run_json(["render", "--terrain", HZP, "--out", out, "--width", "480", "--height", "270"] + cam,
                                 "local render %d" % k)
        check(j and j["tiles_loaded"] > 0 and "http" not in j, "local render %d: %s tiles, no http figures" %
              (k, j and j["tiles_loaded"]))
        local.append(out)
    for k, cam in enumerate(CAMS):
        out = tmp("http%d.png" % k)
        rc, j, err, _ = run_json(["render", "--terrain", ng.url, "--out", out, "--width", "480", "--height", "270"] +
                                 cam, "http render %d" % k)
        if j:
            h = j["http"]
            check(same(out, local[k]), "http render %d is byte-identical to the local-file render" % k)
            check(h["requests"] == j["tiles_loaded"] + 2 and h["failures"] == 0 and h["retries"] == 0 and
                  j["tiles_failed"] == 0,
                  "http render %d: %d requests = header + index + %d tiles, no retry, no failure" %
                  (k, h["requests"], j["tiles_loaded"]))
            tile_bytes = sum(r[1] for r in recs)
            check(0 < h["bytes"] <= 512 + (idx_bytes + 4096) + tile_bytes,
                  "http render %d: %d bytes fetched (file %d)" % (k, h["bytes"], len(data)))
    # keep-alive: the reads of one run come over a few connections
    lines = ng.log_lines()
    conns = {l[0] for l in lines}
    check(all(l[2] == "206" for l in lines), "nginx answered every read with 206 (%d reads)" % len(lines))
    check(len(lines) >= 20 and len(conns) <= len(lines) // 2,
          "keep-alive: %d reads over %d connections" % (len(lines), len(conns)))

    # 2. a short bench over http, and info --verify
    rc, j, err, dt = run_json(["bench", "--terrain", ng.url, "--frames", "40", "--width", "320", "--height", "180"],
                              "http bench")
    if j:
        pf = j["per_frame"]
        ln, nd = sum(f["late_nodes"] for f in pf), sum(f["nodes"] for f in pf)
        check(j["late_nodes"] == ln and j["nodes_drawn"] == nd and abs(j["late_tile_fraction"] - ln / nd) < 1e-12 and
              abs(j["late_frame_fraction"] - sum(f["late_nodes"] > 0 for f in pf) / len(pf)) < 1e-12,
              "late_tile_fraction = late nodes / nodes drawn over the flight (%d / %d)" % (ln, nd))
        check(j["tiles_loaded"] > 0 and j["tiles_failed"] == 0 and j["http"]["failures"] == 0 and
              j["http"]["requests"] > j["tiles_loaded"],
              "http bench: %d frames, %d tiles loaded over %d requests, worst frame %.1f ms" %
              (j["frames"], j["tiles_loaded"], j["http"]["requests"], j["frame_ms_worst"]))
    # every frame of a flight over http is the local-file flight's: --deterministic waits for the
    # tiles each frame wants, and hashes each image
    fl = {}
    for label, src in (("local", HZP), ("http", ng.url)):
        rc, j, err, dt = run_json(["bench", "--terrain", src, "--frames", "40", "--width", "320", "--height", "180",
                                   "--deterministic"], "deterministic bench (%s)" % label)
        if j:
            fl[label] = j
            check(j["pacing"] == "deterministic" and j["late_tile_fraction"] == 0 and len(j["per_frame"]) == 40 and
                  all(len(f["hash"]) == 16 for f in j["per_frame"]),
                  "deterministic flight (%s): 40 frame hashes, no tile late (%.1f s)" % (label, dt))
    if len(fl) == 2:
        hl = [f["hash"] for f in fl["local"]["per_frame"]]
        hh = [f["hash"] for f in fl["http"]["per_frame"]]
        diff = [k for k in range(len(hl)) if k >= len(hh) or hl[k] != hh[k]]
        check(not diff and fl["local"]["flight_hash"] == fl["http"]["flight_hash"],
              "every frame of the flight over http is identical to the local-file flight (%d frames%s)" %
              (len(hl), ", differ at %s" % diff[:8] if diff else ""))
        check(len(set(hl)) >= 30, "the frames differ from each other (%d distinct of %d): the camera flew" %
              (len(set(hl)), len(hl)))
        check(fl["http"]["http"]["bytes"] > 0, "the http flight fetched %d bytes" % fl["http"]["http"]["bytes"])
    rc, out, err, _ = run(["info", ng.url, "--verify"])
    check(rc == 0 and "every tile checks" in out, "info URL --verify reads and checks every tile over http")

    # 3. the disk cache
    dc = tmp("dcache")
    rc, j1, err, _ = run_json(["render", "--terrain", ng.url, "--out", tmp("dc1.png"), "--disk-cache", dc,
                               "--width", "480", "--height", "270"] + CAMS[1], "render filling the disk cache")
    rc, j2, err, _ = run_json(["render", "--terrain", ng.url, "--out", tmp("dc2.png"), "--disk-cache", dc,
                               "--width", "480", "--height", "270"] + CAMS[1], "render from the disk cache")
    if j1 and j2:
        check(j1["http"]["disk_cache_hits"] == 0 and j2["http"]["requests"] == 1 and
              j2["http"]["disk_cache_hits"] == j2["tiles_loaded"] + 1 and same(tmp("dc2.png"), local[1]),
              "warm disk cache: 1 request (the header), %d hits, same image" % j2["http"]["disk_cache_hits"])
    # a damaged entry is refused (checksum) and fetched again
    entries = [os.path.join(r, f) for r, _, fs in os.walk(dc) for f in fs if "-" in f]
    tile_entries = [e for e in entries if int(os.path.basename(e).split("-")[0], 16) not in (0, idx_off)]
    victim = max(tile_entries, key=os.path.getsize)
    b = bytearray(open(victim, "rb").read())
    b[len(b) // 2] ^= 0xFF
    open(victim, "wb").write(bytes(b))
    rc, j3, err, _ = run_json(["render", "--terrain", ng.url, "--out", tmp("dc3.png"), "--disk-cache", dc,
                               "--width", "480", "--height", "270"] + CAMS[1], "render past a damaged cache entry")
    if j3:
        check(j3["http"]["disk_cache_rejected"] == 1 and j3["http"]["requests"] == 2 and
              same(tmp("dc3.png"), local[1]), "a damaged cache entry is refused by its checksum and fetched again")
    # an entry whose own checksum holds but whose bytes are not the tile the index names (another
    # version, a forged file): refused by the index's checksum
    check(xxh64(data[recs[0][0]:recs[0][0] + recs[0][1]]) == recs[0][3], "the test's XXH64 matches the index's")
    b = bytearray(open(victim, "rb").read()[:-8])
    b[len(b) // 3] ^= 0x01
    open(victim, "wb").write(bytes(b) + struct.pack("<Q", xxh64(bytes(b))))
    rc, j3, err, _ = run_json(["render", "--terrain", ng.url, "--out", tmp("dc3.png"), "--disk-cache", dc,
                               "--width", "480", "--height", "270"] + CAMS[1], "render past a forged cache entry")
    if j3:
        check(j3["http"]["disk_cache_rejected"] == 1 and j3["http"]["requests"] == 2 and
              same(tmp("dc3.png"), local[1]), "a cache entry that is not the indexed tile is refused and fetched again")
    # the bound: a bench reads more than 1 MB (the coarse level whole, then the flight)
    small = tmp("dsmall")
    rc, j4, err, _ = run_json(["bench", "--terrain", ng.url, "--frames", "40", "--width", "320", "--height", "180",
                               "--disk-cache", small, "--disk-cache-mb", "1"], "bench with a 1 MB disk cache")
    if j4:
        held = sum(os.path.getsize(e) for r, _, fs in os.walk(small) for e in [os.path.join(r, f) for f in fs])
        # (the bench opens the pyramid three times; the JSON has the flight's figures)
        check(j4["http"]["disk_cache_evicted"] > 0 and held <= (1 << 20) + 4096,
              "--disk-cache-mb 1: %d entries evicted by the flight, %d bytes held" %
              (j4["http"]["disk_cache_evicted"], held))
    # offline: nginx stopped, the warm cache still renders the same image
    ng.stop()
    rc, j5, err, dt = run_json(["render", "--terrain", ng.url, "--out", tmp("off.png"), "--disk-cache", dc,
                                "--width", "480", "--height", "270"] + CAMS[1], "offline render")
    if j5:
        check(j5["http"]["offline"] and j5["tiles_failed"] == 0 and same(tmp("off.png"), local[1]),
              "server stopped: the warm disk cache renders the same image (%.1f s)" % dt)
        check("disk cache" in err, "offline is said on stderr")
    # offline, a view the cache lacks tiles of: drawn coarser there, at once (the server is not asked
    # again for every tile after a read found nobody)
    rc, j6, err, dt = run_json(["render", "--terrain", ng.url, "--out", tmp("off0.png"), "--disk-cache", dc,
                                "--width", "480", "--height", "270"] + CAMS[0], "offline render, tiles missing")
    if j6:
        # 5 attempts at the header at open; then no missing tile costs its 5 attempts again
        check(j6["tiles_failed"] >= 1 and j6["http"]["requests"] < 5 + 5 * j6["tiles_failed"] and dt < 30 and
              "drawing the coarser level" in err,
              "offline, %d tiles not in the cache: drawn coarser with a warning, %d requests, %.1f s" %
              (j6["tiles_failed"], j6["http"]["requests"], dt))
    rc, out, err, dt = run(["render", "--terrain", ng.url, "--out", tmp("none.png")])
    check(rc == 1 and "cannot read" in err and "Couldn't connect" in err and dt < 30,
          "server stopped, no cache: a clear error in %.1f s (%s)" % (dt, err.strip()[:160]))
finally:
    ng.stop()

# 4. faults, through the proxy in front of a fresh nginx
ng = Nginx(www, tmp("nginx"))
try:
    px = Proxy(ng.port, "flaky", delay=2.0)
    rc, j, err, dt = run_json(["render", "--terrain", px.url, "--out", tmp("flaky.png"), "--width", "480", "--height",
                               "270", "--http-timeout", "1"] + CAMS[1], "render through the flaky proxy", timeout=240)
    px.stop()
    if j:
        h = j["http"]
        reads = j["tiles_loaded"] + 2
        check(same(tmp("flaky.png"), local[1]) and j["tiles_failed"] == 0 and h["failures"] == 0,
              "500, dropped connection and timeout on the first 3 attempts of every read: retried, same image "
              "(%.1f s)" % dt)
        check(h["retries"] == 3 * reads and px.counts.get("drop") == reads and px.counts.get("delay") == reads,
              "every read retried 3 times (%d retries for %d reads; proxy: %s)" % (h["retries"], reads, px.counts))
        check("retried" in err, "the retries are said on stderr")
    # several requests in flight: a pyramid of 16-sample tiles, where a view wants many tiles of one
    # level at once (tiles load level after level: a tile needs its parent's for its morph data)
    rc, _, err, _ = run(["import", "--generate", "perlin", "--size", "1025", "--seed", "7", "--tile", "16", "--out",
                         os.path.join(www, "t16.hzp"), "--quiet"])
    px2 = Proxy(ng.port, "pass", latency=0.2, name="t16.hzp")
    rc, j2, err, dt = run_json(["render", "--terrain", px2.url, "--out", tmp("t16.png"), "--width", "480",
                                "--height", "270"] + CAMS[1], "render with 200 ms per request", timeout=240)
    px2.stop()
    check(px2.max_inflight >= 3, "several requests in flight: up to %d at once" % px2.max_inflight)

    px = Proxy(ng.port, "fail1", targets=LEVEL1)
    rc, j, err, dt = run_json(["render", "--terrain", px.url, "--out", tmp("fail1.png"), "--width", "480", "--height",
                               "270"] + CAMS[1], "render with level-1 tiles failing", timeout=240)
    if j:
        check(rc == 0 and j["tiles_failed"] >= 1 and j["http"]["failures"] == j["tiles_failed"] and
              "drawing the coarser level" in err and "HTTP 500" in err and os.path.getsize(tmp("fail1.png")) > 0,
              "a tile that always fails (500): %d tiles drawn coarser, warning, exit 0 (%.1f s)" %
              (j["tiles_failed"], dt))
    # (one retry: the failures land within the flight, which never waits for a tile)
    rc, j, err, dt = run_json(["bench", "--terrain", px.url, "--frames", "60", "--width", "320", "--height", "180",
                               "--http-retries", "1"], "bench with level-1 tiles failing", timeout=240)
    px.stop()
    if j:
        check(rc == 0 and j["tiles_failed"] >= 1 and "warning" in j and j["http"]["failures"] >= 1,
              "the flight completes with %d tiles failed, a warning and the figures (%.1f s)" % (j["tiles_failed"], dt))

    px = Proxy(ng.port, "corrupt1", targets=LEVEL1)
    rc, j, err, dt = run_json(["render", "--terrain", px.url, "--out", tmp("corrupt1.png"), "--width", "480",
                               "--height", "270"] + CAMS[1], "render with corrupt level-1 tiles", timeout=240)
    px.stop()
    if j:
        check(rc == 0 and j["tiles_failed"] >= 1 and "checksum" in err and px.counts.get("corrupt", 0) >= 5 and
              j["http"]["retries"] >= 4, "a tile arriving corrupt is caught by its checksum, retried, then drawn "
              "coarser (%d tiles; %s)" % (j["tiles_failed"], err.strip().splitlines()[0][:200]))

    px = Proxy(ng.port, "norange")
    rc, out, err, dt = run(["render", "--terrain", px.url, "--out", tmp("norange.png")])
    px.stop()
    check(rc == 1 and "range requests" in err and dt < 30, "a server ignoring ranges is refused (%s)" % err.strip())
finally:
    ng.stop()

finish()
