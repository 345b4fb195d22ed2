#!/usr/bin/env python3
"""out/bench/pyramids/*.json -> the pyramid tables (markdown)."""
import json, os, sys

P = sys.argv[1]

def load(name):
    f = os.path.join(P, name + ".json")
    return json.load(open(f)) if os.path.exists(f) else None

def rss(name):
    f = os.path.join(P, name + ".rss")
    try:
        return int(open(f).read().split()[-1]) / 1024.0
    except (OSError, ValueError, IndexError):
        return float("nan")

print("## Terrain pyramids\n")
print("| run | figures |")
print("|---|---|")
for tag, label in (("g16k", "16385² generated (268 M samples)"), ("g64k", "65537² generated (4.3 G samples)")):
    imp = load(tag + "_import")
    if imp:
        print(f"| {label}: import | {imp['ms']/1000:.0f} s, peak RSS {rss(tag + '_import'):.0f} MB, "
              f"{imp['bytes']/1e6:.0f} MB on disk, {imp['bytes_per_sample']:.3f} bytes/sample, "
              f"max error {imp['max_error_m']:.3g} m |")
    fly = load(tag + "_fly")
    if fly:
        print(f"| {label}: flyover, {fly['cache_mb_limit']:.0f} MB cache | peak RSS {rss(tag + '_fly'):.0f} MB, "
              f"{fly['triangles_median']:.0f} triangles, LOD {fly['lod_ms_median']:.2f} ms, frame median "
              f"{fly['frame_ms_median']:.1f} / worst {fly['frame_ms_worst']:.1f} ms, late frames "
              f"{100*fly['late_frame_fraction']:.1f} %, {fly['tiles_loaded']} tiles loaded, "
              f"{fly['tiles_evicted']} evicted, cache ≤ {fly['cache_mb_max']:.0f} MB |")
m = load("m4k_fly")
if m:
    print(f"| 4097² perlin in memory, same flyover | {m['triangles_median']:.0f} triangles, LOD "
          f"{m['lod_ms_median']:.2f} ms, frame median {m['frame_ms_median']:.1f} ms, peak RSS {rss('m4k_fly'):.0f} MB |")
fs, fm = load("f4097_fly"), load("f4097_mem")
if fs and fm:
    print(f"| peers' 4097² map, streamed | {fs['triangles_median']:.0f} triangles, LOD {fs['lod_ms_median']:.2f} ms, "
          f"frame {fs['frame_ms_median']:.1f} ms, peak RSS {rss('f4097_fly'):.0f} MB |")
    print(f"| peers' 4097² map, in memory | {fm['triangles_median']:.0f} triangles, LOD {fm['lod_ms_median']:.2f} ms, "
          f"frame {fm['frame_ms_median']:.1f} ms, peak RSS {rss('f4097_mem'):.0f} MB |")
    print(f"| streamed / in memory | triangles {fs['triangles_median']/fm['triangles_median']:.2f}×, "
          f"LOD {fs['lod_ms_median']/max(fm['lod_ms_median'],1e-9):.2f}× |")
ss = load("f4097_select")
if ss:
    print(f"| peers' 4097² map: selection CPU time, same cameras (bench/stream_select, best of {ss['runs']}) | "
          f"streamed {ss['stream_ms']:.3f} ms vs in memory {ss['memory_ms']:.3f} ms per frame = {ss['ratio']:.2f}× "
          f"(goal ≤ 1.2×), {ss['stream_triangles']:.0f} vs {ss['memory_triangles']:.0f} triangles, "
          f"{ss['stream_nodes']:.0f} vs {ss['memory_nodes']:.0f} nodes |")
si, sn = load("sierra_import"), load("sierra_info")
if si and sn:
    d = sn[0]
    c = d.get("corners_lonlat", {})
    corners = ", ".join(f"{k.upper()} {v[0]:.4f} {v[1]:.4f}" for k, v in c.items())
    print(f"| srtm_sierra_coast (24 tiles) | {d['width']}×{d['height']} samples at {d['spacing']:.1f} m, {d['crs']}, "
          f"{corners}; nodata {100*d['nodata_fraction']:.1f} %; import {si['ms']/1000:.0f} s, "
          f"{si['bytes']/1e6:.0f} MB ({d['bytes_per_sample']:.2f} bytes/sample of data), lossless |")
ij = load("import_jobs")
if ij:
    import statistics
    runs = ij["runs"]
    print(f"\n### Import of {ij['source']} in parallel jobs ({ij['jobs']} jobs, --tiles A-A / --finish; "
          f"{ij['cores']} cores, shared with other work; medians of {len(runs) // 4 or 1} runs)\n")
    print("| import | wall time s (median) | runs s |")
    print("|---|---|---|")
    one = [r["s"] for r in runs if r["mode"] == "one run"]
    if one:
        print(f"| one run (`--threads {runs[0].get('threads', '')}`) | {statistics.median(one):.1f} | "
              f"{', '.join(f'{v:.1f}' for v in one)} |")
    for par in (1, 2, 4):
        v = [r["s"] for r in runs if r["mode"] == "parallel" and r["parallel"] == par]
        if v:
            print(f"| GNU parallel -j {par}, `--threads 1` per job, + `--finish` | {statistics.median(v):.1f} | "
                  f"{', '.join(f'{x:.1f}' for x in v)} |")
