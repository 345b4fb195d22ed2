#!/usr/bin/env python3
"""Turns out/bench/*.json into markdown tables (stdout): the single runs, and
the LOD mode comparisons (files holding {"compare": [...]})."""
import glob, json, os, sys

d = sys.argv[1] if len(sys.argv) > 1 else "out/bench"
rows, compares = [], []
effects = None
for f in sorted(glob.glob(os.path.join(d, "*.json"))):
    try:
        j = json.load(open(f))
    except (OSError, ValueError):
        continue
    name = os.path.basename(f)[:-5]
    if name == "effects" and isinstance(j, dict) and isinstance(j.get("effects"), dict):
        effects = j
        continue
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
            if j.get("near_pixel_error"):
                lod += " ({:g} within {:g} m)".format(j["near_pixel_error"], j["near_error_distance"])
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

# The forest table (SPEC F7), next to the seed's figures.
fp = os.path.join(d, "forest.json")
if os.path.exists(fp):
    try:
        f = json.load(open(fp))
    except (OSError, ValueError):
        f = None
    if f:
        print()
        print("### Forest ({} trees on {}, path {}, {} frames at {}x{})".format(
            f["trees"], f["terrain"], f["path"], f["frames"], f["width"], f["height"]))
        print()
        def n(v, fmt):
            return "-" if v is None else format(v, fmt)
        print("Median over frames (p95 in brackets); CPU ms = all threads of the process (the machine may be shared).")
        print()
        print("| figure | hysteresis | no hysteresis | unsimplified | bare terrain | seed (F7) |")
        print("|---|---|---|---|---|---|")
        frows = [
            ("frame ms", "{} ({})".format(n(f.get("frame_ms"), ".1f"), n(f.get("frame_ms_p95"), ".1f")),
             "{} ({})".format(n(f.get("frame_ms_no_hysteresis"), ".1f"), n(f.get("frame_ms_p95_no_hysteresis"), ".1f")),
             "{} ({})".format(n(f.get("frame_ms_full"), ".0f"), n(f.get("frame_ms_p95_full"), ".0f")),
             "{} ({})".format(n(f.get("frame_ms_terrain"), ".1f"), n(f.get("frame_ms_p95_terrain"), ".1f")),
             "33.1 / 57"),
            ("CPU ms", n(f.get("cpu_ms"), ".1f"), n(f.get("cpu_ms_no_hysteresis"), ".1f"), n(f.get("cpu_ms_full"), ".0f"),
             n(f.get("cpu_ms_terrain"), ".1f"), ""),
            ("triangles drawn", n(f.get("triangles_drawn"), ".0f"), n(f.get("triangles_drawn_no_hysteresis"), ".0f"),
             n(f.get("triangles_drawn_full"), ".0f"), "", "2.00 M of 42.51 M"),
            ("trees in frustum: leaves / hulls / impostors",
             "{} / {} / {}".format(n(f.get("trees_leaves"), ".0f"), n(f.get("trees_hull"), ".0f"), n(f.get("trees_impostor"), ".0f")),
             "{} / {} / {}".format(n(f.get("trees_leaves_no_hysteresis"), ".0f"), n(f.get("trees_hull_no_hysteresis"), ".0f"),
                                   n(f.get("trees_impostor_no_hysteresis"), ".0f")),
             n(f.get("trees_in_frustum_full"), ".0f"), "", "621"),
            ("forest draw ms: leaves / bark + hulls / impostors (timed apart)",
             "{} / {} / {}".format(n(f.get("forest_leaves_ms"), ".1f"), n(f.get("forest_hulls_ms"), ".1f"),
                                   n(f.get("forest_impostors_ms"), ".1f")), "", "", "", ""),
            ("selection CPU ms", n(f.get("select_ms"), ".2f"), n(f.get("select_ms_no_hysteresis"), ".2f"), n(f.get("select_ms_full"), ".2f"), "", ""),
            ("upload bytes / frame", n(f.get("upload_bytes"), ".0f"), n(f.get("upload_bytes_no_hysteresis"), ".0f"), "", "", ""),
            ("nodes changed / frame", n(f.get("nodes_changed"), ".0f"), n(f.get("nodes_changed_no_hysteresis"), ".0f"), "", "", ""),
        ]
        for r in frows:
            print("| {} | {} | {} | {} | {} | {} |".format(*r))
        print()
        print("Speed-up over unsimplified on the same {} frames: {}x (seed 15.18x); simplified / bare terrain: {}x; "
              "against unsimplified: PSNR {} dB, tree silhouette error {} % of pixels.".format(
                  f.get("full_frames"), n(f.get("speedup"), ".1f"), n(f.get("terrain_ratio"), ".2f"),
                  n(f.get("psnr_db"), ".1f"), n(None if f.get("silhouette_frac") is None else 100 * f["silhouette_frac"], ".2f")))
        print()
        sp = f.get("species", [])
        if sp and "vmi_precision" in sp[0]:
            print("Image similarity at 50 % simplification ({} views at {} px), foliage coverage precision / recall:".format(sp[0]["pr_views"], sp[0]["pr_res"]))
            print()
            print("| species | leaves | triangles | hull tris | rank s | MB | VMI P/R | VMI enlarged P/R | random P/R | random enlarged P/R |")
            print("|---|---|---|---|---|---|---|---|---|---|")
            for s in sp:
                print("| {} | {} | {} | {} | {:.1f} | {:.1f} | {:.3f} / {:.3f} | {:.3f} / {:.3f} | {:.3f} / {:.3f} | {:.3f} / {:.3f} |".format(
                    s["name"], s["leaves"], s["triangles"], s["hull_triangles"], s["rank_ms"] / 1000, s["memory_mb"],
                    s["vmi_precision"], s["vmi_recall"], s["vmi_enlarged_precision"], s["vmi_enlarged_recall"],
                    s["random_precision"], s["random_recall"], s["random_enlarged_precision"], s["random_enlarged_recall"]))
            print("| seed | 53 912 – 292 581 | 133 327 – 811 710 | 4 198 (oak) | | | 0.95 / 0.82 and 0.96 / 0.88 | | 0.90 / 0.71 and 0.92 / 0.78 | |")
            if "vmi_leaf_precision" in sp[0]:
                print()
                print("The same renders by the same leaf in each pixel (a leaf exposed by pruning, or an enlarged leaf over "
                      "a removed one, counts against the simplified tree), precision / recall:")
                print()
                print("| species | VMI | VMI enlarged | random | random enlarged |")
                print("|---|---|---|---|---|")
                for s in sp:
                    print("| {} | {:.3f} / {:.3f} | {:.3f} / {:.3f} | {:.3f} / {:.3f} | {:.3f} / {:.3f} |".format(
                        s["name"], s["vmi_leaf_precision"], s["vmi_leaf_recall"], s["vmi_enlarged_leaf_precision"],
                        s["vmi_enlarged_leaf_recall"], s["random_leaf_precision"], s["random_leaf_recall"],
                        s["random_enlarged_leaf_precision"], s["random_enlarged_leaf_recall"]))

if effects:
    e = effects
    print()
    print("## Effects: frame-time cost at {}x{} ({}, path {}, {} frames, {})".format(
        e["width"], e["height"], e["terrain"], e["path"], e["frames"], e.get("gl", "")))
    print()
    print("Median over frames of the per-frame difference in draw ms (CPU work of the effects included). "
          "Alone, motionblur and bloom also pay for rendering the scene to a texture and the final pass "
          "of the chain, which they share when both are on.")
    print("Bare terrain {:.1f} ms, everything on {:.1f} ms.".format(e["base_ms"], e["all_ms"]))
    print()
    print("| effect | alone: + ms over the bare terrain | in all: - ms when taken out |")
    print("|---|---|---|")
    for name, v in e["effects"].items():
        print("| {} | {:.1f} | {:.1f} |".format(name, v["alone_ms"], v["in_all_ms"]))
    print()
    print("Light map with shadows at {0}x{0}: {1:.0f} ms on 1 thread, {2:.0f} ms on 2 threads.".format(
        e["lightmap_size"], e["lightmap_ms_1thread"], e["lightmap_ms_2threads"]))
