#!/usr/bin/env python3
"""Pyramids over HTTP (issue 17 figures): a real nginx on 127.0.0.1 and a proxy
adding 50 ms to every request in front of it, a generated 4097^2 pyramid.
- tiles/s and MB/s reading every tile (build/bench/pyramid_fetch): local file,
  nginx with 1 and 8 connections, with a cold and a warm disk cache, and
  through the 50 ms proxy with 1 and 8 connections;
- the flyover flight (horizon bench) from the file, from nginx and through
  the 50 ms proxy: worst frame, late frames, late nodes / nodes, bytes fetched.
Writes OUT/http.json and prints a table. Figures are medians of RUNS runs.
usage: bench/http_bench.py HORIZON OUT_DIR"""
import json, os, shutil, statistics, subprocess, sys, tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "cli"))
from http_fixtures import Nginx, Proxy  # noqa: E402

HZ, OUT = os.path.abspath(sys.argv[1]), sys.argv[2]
FETCH = os.path.join(os.path.dirname(HZ), "..", "..", "bench", "pyramid_fetch")
RUNS = int(os.environ.get("RUNS", "3"))
os.makedirs(OUT, exist_ok=True)
work = tempfile.mkdtemp(prefix="hz_http_bench.")
os.chmod(work, 0o755)  # nginx's workers run as another user when started by root
www = os.path.join(work, "www")
os.makedirs(www)
subprocess.run([HZ, "import", "--generate", "perlin", "--size", "4097", "--seed", "1", "--out",
                os.path.join(www, "big.hzp"), "--quiet"], check=True)
res = {"pyramid": "perlin 4097, seed 1", "runs": RUNS, "fetch": [], "flight": []}
ng = Nginx(www, os.path.join(work, "nginx"), name="big.hzp")
px = Proxy(ng.port, "pass", latency=0.05, name="big.hzp")
try:
    def fetch(label, src, threads, cache=None):
        rows = []
        for r in range(RUNS):
            args = [FETCH, src, "--threads", str(threads)]
            if cache:
                dc = os.path.join(work, "dc%d" % r)
                args += ["--disk-cache", dc, "--rounds", "2"]
            out = subprocess.run(args, capture_output=True, text=True, check=True).stdout.splitlines()
            rows.append(json.loads(out[-1 if cache == "warm" else 0]))
        row = {"source": label, "threads": threads,
               "tiles_per_s": statistics.median(x["tiles_per_s"] for x in rows),
               "mb_per_s": statistics.median(x["mb_per_s"] for x in rows),
               "requests": rows[0]["requests"], "tiles": rows[0]["tiles"]}
        res["fetch"].append(row)
        print("%-28s %2d threads: %6.0f tiles/s %6.1f MB/s, %d requests" %
              (label, threads, row["tiles_per_s"], row["mb_per_s"], row["requests"]), flush=True)

    local = os.path.join(www, "big.hzp")
    fetch("file", local, 1)
    fetch("file", local, 2)
    for t in (1, 2, 8):
        fetch("nginx", ng.url, t)
    fetch("nginx, cold disk cache", ng.url, 2, "cold")
    fetch("nginx, warm disk cache", ng.url, 2, "warm")
    for t in (1, 8):
        fetch("nginx + 50 ms", px.url, t)

    for label, src in (("file", local), ("nginx", ng.url), ("nginx + 50 ms", px.url)):
        rows = []
        for r in range(RUNS):
            out = subprocess.run([HZ, "bench", "--terrain", src, "--path", "flyover", "--json"], capture_output=True,
                                 text=True, check=True).stdout
            j = json.loads(out)
            pf = j.pop("per_frame")
            rows.append({"worst_ms": j["frame_ms_worst"], "median_ms": j["frame_ms_median"],
                         "late_frames": j["late_frame_fraction"],
                         "late_nodes": sum(f["late_nodes"] for f in pf) / max(1, sum(f["nodes"] for f in pf)),
                         "tiles_loaded": j["tiles_loaded"], "tiles_failed": j["tiles_failed"],
                         "bytes": j.get("http", {}).get("bytes", 0)})
        row = {"source": label}
        for k in rows[0]:
            row[k] = statistics.median(x[k] for x in rows)
        res["flight"].append(row)
        print("flyover %-16s worst %6.1f ms, median %5.1f ms, late frames %.3f, late nodes %.4f, %d tiles, %d bytes"
              % (label, row["worst_ms"], row["median_ms"], row["late_frames"], row["late_nodes"],
                 row["tiles_loaded"], row["bytes"]), flush=True)
finally:
    px.stop()
    ng.stop()
    shutil.rmtree(work, ignore_errors=True)
with open(os.path.join(OUT, "http.json"), "w") as f:
    json.dump(res, f, indent=1)
