#!/usr/bin/env python3
"""Turns out/bench/*.json into one markdown table (stdout)."""
import glob, json, os, sys

d = sys.argv[1] if len(sys.argv) > 1 else "out/bench"
rows = []
for f in sorted(glob.glob(os.path.join(d, "*.json"))):
    try:
        j = json.load(open(f))
    except (OSError, ValueError):
        continue
    if "frames" not in j or "triangles_median" not in j:
        continue
    rows.append((os.path.basename(f)[:-5], j))

def num(v, fmt):
    return "—" if v is None else format(v, fmt)

print("| run | terrain | size | C / C2 | criterion | path | frames | triangles median (p95) | "
      "LOD ms median | draw ms median | frame ms median | px err p99 / max | PSNR dB | "
      "silhouette | popping | B/sample | peak RSS MB |")
print("|" + "---|" * 17)
for name, j in rows:
    print("| {} | {} | {} | {:g} / {:g} | {} | {} | {} | {:.0f} ({:.0f}) | {} | {} | {} | {} / {} | {} | {} | {} | {:.2f} | {:.0f} |".format(
        name, j["terrain"], j["size"], j["lod_c"], j["lod_c2"], j.get("criterion", ""), j["path"], j["frames"],
        j["triangles_median"], j["triangles_p95"], num(j["lod_ms_median"], ".3f"), num(j["draw_ms_median"], ".1f"),
        num(j["frame_ms_median"], ".1f"), num(j["px_error_p99"], ".2f"), num(j["px_error_max"], ".1f"),
        num(j.get("psnr_db_median"), ".1f"), num(j.get("silhouette_frac"), ".4f"), num(j.get("popping"), ".3f"),
        j["bytes_per_sample"], j["peak_rss_mb"]))
