#!/usr/bin/env python3
"""Turns out/bench/*.json into markdown tables (stdout): the single runs, and
the LOD mode comparisons (files holding {"compare": [...]})."""
import glob, json, os, sys

d = sys.argv[1] if len(sys.argv) > 1 else "out/bench"
rows, compares = [], []
for f in sorted(glob.glob(os.path.join(d, "*.json"))):
    try:
        j = json.load(open(f))
    except (OSError, ValueError):
        continue
    name = os.path.basename(f)[:-5]
    if isinstance(j, dict) and "compare" in j:
        compares.append((name, j["compare"]))
    elif isinstance(j, dict) and "frames" in j and "triangles_median" in j:
        rows.append((name, j))


def num(v, fmt):
    return "—" if v is None else format(v, fmt)


if rows:
    print("| run | terrain | size | LOD | path | frames | triangles median (p95) | "
          "LOD ms median | draw ms median | frame ms median | px err p99 / max | PSNR dB | "
          "silhouette | popping | B/sample | peak RSS MB |")
    print("|" + "---|" * 16)
    for name, j in rows:
        if j.get("pixel_error") or j.get("lod_mode") in ("roam", "cdlod"):
            lod = "{} τ={:g}".format(j.get("lod_mode", "quadtree"), j.get("pixel_error") or 1)
        else:
            lod = "{} C={:g} C2={:g} {}".format(j.get("lod_mode", "quadtree"), j["lod_c"], j["lod_c2"],
                                               j.get("criterion", ""))
        print("| {} | {} | {} | {} | {} | {} | {:.0f} ({:.0f}) | {} | {} | {} | {} / {} | {} | {} | {} | {:.2f} | {:.0f} |".format(
            name, j["terrain"], j["size"], lod, j["path"], j["frames"],
            j["triangles_median"], j["triangles_p95"], num(j["lod_ms_median"], ".3f"), num(j["draw_ms_median"], ".1f"),
            num(j["frame_ms_median"], ".1f"), num(j["px_error_p99"], ".2f"), num(j["px_error_max"], ".1f"),
            num(j.get("psnr_db_median"), ".1f"), num(j.get("silhouette_frac"), ".4f"), num(j.get("popping"), ".3f"),
            j["bytes_per_sample"], j["peak_rss_mb"]))

if compares:
    print()
    print("LOD modes compared: each mode tuned (`--tune-p99`) to the largest pixel error bound whose 99th-percentile "
          "screen-space error stays within the target; same path and reference frames for every mode. "
          "`pop px` is the geometric popping: the largest jump of the drawn surface between two frames, "
          "in pixels (median over frames / p95); `popping` the image measure.")
    print()
    print("| terrain | path | p99 target | mode | τ found | triangles median (p95) | LOD ms median | "
          "frame ms median | px err p99 / max | PSNR dB | popping | pop px median / p95 | B/sample |")
    print("|" + "---|" * 13)
    for name, runs in compares:
        for j in runs:
            print("| {} {} | {} | {:g} px | {} | {:.3g} | {:.0f} ({:.0f}) | {} | {} | {} / {} | {} | {} | {} / {} | {:.2f} |".format(
                j["terrain"], j["size"], j["path"], j.get("tuned_for_p99") or 0, j["lod_mode"], j["pixel_error"],
                j["triangles_median"], j["triangles_p95"], num(j["lod_ms_median"], ".3f"),
                num(j["frame_ms_median"], ".1f"), num(j["px_error_p99"], ".2f"), num(j["px_error_max"], ".1f"),
                num(j.get("psnr_db_median"), ".1f"), num(j.get("popping"), ".3f"),
                num(j.get("pop_px_max_median"), ".3f"), num(j.get("pop_px_max_p95"), ".3f"), j["bytes_per_sample"]))
