#!/usr/bin/env python3
"""Pyramids over HTTP (issue 17 figures): a real nginx on 127.0.0.1 and a proxy
adding 50 ms to every request in front of it, a generated 4097^2 pyramid.
- tiles/s and MB/s reading every tile (build/bench/pyramid_fetch): local file,
  nginx with 1 and 8 connections, with a cold and a warm disk cache, and
  through the 50 ms proxy with 1 and 8 connections;
- the flyover flight (horizon bench) from the file, from nginx and through
  the 50 ms proxy, paced as a viewer flies it (--realtime, 30 fps) and
  unpaced: worst frame, late-tile and late-frame fractions, bytes fetched;
- a --deterministic flight from each source: every frame's hash against the
  file's.
Writes OUT/http.json and OUT/http.md. Figures are medians of RUNS runs.
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

    # The flyover as a viewer flies it (--realtime: 30 fps slots, the camera on the wall clock) and
    # unpaced (frames as fast as they draw: the camera 5-20x faster than real time).
    # late_tile_fraction: nodes drawn coarser than the LOD wanted because a tile was missing /
    # nodes drawn, over the flight.
    for pacing, extra in (("realtime 30 fps", ["--realtime", "--fps", "30"]), ("unpaced 120 frames", ["--frames", "120"])):
        for label, src in (("file", local), ("nginx", ng.url), ("nginx + 50 ms", px.url)):
            rows = []
            for r in range(RUNS):
                out = subprocess.run([HZ, "bench", "--terrain", src, "--path", "flyover", "--json"] + extra,
                                     capture_output=True, text=True, check=True).stdout
                j = json.loads(out)
                j.pop("per_frame")
                rows.append({"frames": j["frames"], "frames_dropped": j.get("frames_dropped", 0),
                             "worst_ms": j["frame_ms_worst"], "median_ms": j["frame_ms_median"],
                             "late_frames": j["late_frame_fraction"], "late_tiles": j["late_tile_fraction"],
                             "tiles_loaded": j["tiles_loaded"], "tiles_failed": j["tiles_failed"],
                             "bytes": j.get("http", {}).get("bytes", 0), "flight_s": j["flight_seconds"]})
            row = {"source": label, "pacing": pacing}
            for k in rows[0]:
                row[k] = statistics.median(x[k] for x in rows)
            row["late_tiles_max"] = max(x["late_tiles"] for x in rows)
            res["flight"].append(row)
            print("flyover %-18s %-14s %4d frames (%d dropped), worst %6.1f ms, median %5.1f ms, late frames %.4f, "
                  "late tiles %.5f, %d tiles, %d bytes" % (pacing, label, row["frames"], row["frames_dropped"],
                                                          row["worst_ms"], row["median_ms"], row["late_frames"],
                                                          row["late_tiles"], row["tiles_loaded"], row["bytes"]),
                  flush=True)
    # Frames identical: a --deterministic flight (each frame waits for its tiles) from each source,
    # compared image hash by image hash.
    hashes = {}
    for label, src in (("file", local), ("nginx", ng.url), ("nginx + 50 ms", px.url)):
        out = subprocess.run([HZ, "bench", "--terrain", src, "--path", "flyover", "--frames", "120",
                              "--deterministic", "--json"], capture_output=True, text=True, check=True).stdout
        j = json.loads(out)
        hashes[label] = [f["hash"] for f in j["per_frame"]]
        res.setdefault("deterministic", []).append({"source": label, "frames": j["frames"],
                                                    "flight_hash": j["flight_hash"],
                                                    "bytes": j.get("http", {}).get("bytes", 0),
                                                    "identical_to_file": hashes[label] == hashes["file"]})
        print("deterministic %-14s %d frames, flight hash %s, identical to the file's: %s" %
              (label, j["frames"], j["flight_hash"], hashes[label] == hashes["file"]), flush=True)
finally:
    px.stop()
    ng.stop()
    shutil.rmtree(work, ignore_errors=True)
with open(os.path.join(OUT, "http.json"), "w") as f:
    json.dump(res, f, indent=1)
md = ["## Pyramids over HTTP (loopback nginx, %s, medians of %d runs; 2 shared cores)\n" % (res["pyramid"], RUNS),
      "| read | threads | tiles/s | MB/s | requests |", "|---|---|---|---|---|"]
md += ["| %s | %d | %.0f | %.1f | %d |" % (r["source"], r["threads"], r["tiles_per_s"], r["mb_per_s"], r["requests"])
       for r in res["fetch"]]
md += ["", "Flyover (1280x720, cdlod 1 px, 256 MB cache). late tiles: nodes drawn coarser than the LOD wanted "
       "because a tile was not resident / nodes drawn, over the flight; late frames: frames with any.\n",
       "| flight | source | frames (dropped) | median ms | worst ms | late tiles | late frames | tiles | bytes fetched |",
       "|---|---|---|---|---|---|---|---|---|"]
md += ["| %s | %s | %d (%d) | %.1f | %.1f | %.3f %% | %.2f %% | %d | %d |" %
       (r["pacing"], r["source"], r["frames"], r["frames_dropped"], r["median_ms"], r["worst_ms"],
        100 * r["late_tiles"], 100 * r["late_frames"], r["tiles_loaded"], r["bytes"]) for r in res["flight"]]
md += ["", "Deterministic flight (each frame waits for its tiles), 120 frames: every frame's image hash "
       "against the local file's.\n", "| source | frames | identical to the file | bytes fetched |", "|---|---|---|---|"]
md += ["| %s | %d | %s | %d |" % (r["source"], r["frames"], "yes, every frame" if r["identical_to_file"] else "NO",
                                 r["bytes"]) for r in res.get("deterministic", [])]
with open(os.path.join(OUT, "http.md"), "w") as f:
    f.write("\n".join(md) + "\n")
print("\n".join(md))
