#!/usr/bin/env bash
# Issue 13's city figures: a procedural city of 20 035 buildings on the real
# Heidelberg DEM (street-level and overview paths, every culling / render
# queue stage on and off in the same run) and the Mamre CityJSON model (load,
# triangles, frame, picking a known osm_id by its pixel).
# Writes OUT/city_*.json and OUT/city.md.
#   bench/city.sh [HORIZON_BINARY] [DATA_DIR] [OUT_DIR]
set -euo pipefail
HZ=${1:-build/apps/horizon/horizon}
DATA=${2:-../shared/data}
OUT=${3:-out/bench}
FR=${CITY_FRAMES:-12}
mkdir -p "$OUT"
echo "== city: procedural 30 x 30 blocks on heidelberg, street and overview ($FR frames each)" >&2
"$HZ" city --quiet --blocks 30 --dem "$DATA/heidelberg_dem_hd_utm32n_25m_float32.tif" --out "$OUT/city_scene.json" >/dev/null
for path in street overview; do
  "$HZ" render --quiet --scene "$OUT/city_scene.json" --effects none --city-bench $path --city-bench-frames "$FR" \
    --json --out "$OUT/city_$path.png" > "$OUT/city_$path.json"
done
echo "== city: mamre CityJSON on its TIN, pick osm_328118446" >&2
"$HZ" render --quiet --city "$DATA/city/mamre_lod1_epsg32734.city.json" --effects none --json \
  --out "$OUT/city_mamre.png" > "$OUT/city_mamre.json"
"$HZ" render --quiet --city "$DATA/city/mamre_lod1_epsg32734.city.json" --effects none --json \
  --camera 1103.5,400,313,0,-89.9 --pick 640,360 --out "$OUT/city_mamre_pick.png" > "$OUT/city_mamre_pick.json"
python3 - "$OUT" > "$OUT/city.md" <<'PY'
import json, sys
out = sys.argv[1]
print("## City (issue 13): procedural city on the Heidelberg DEM, Mamre CityJSON\n")
for path in ("street", "overview"):
    d = json.load(open(f"{out}/city_{path}.json"))
    print(f"**{path}** path: {d['frames']} frames, {d['objects']} objects in the scene, {d['width']}x{d['height']}, "
          "--effects none; frame ms = median over frames of the whole frame (terrain, sky, objects) plus the "
          "occlusion buffer; diff = most pixels of a frame differing from the unculled frame drawn in the same queue order\n")
    print("| culling | queue | frame ms | after frustum | after occlusion | draw calls | state changes | occlusion ms (buffer or queries) | terrain patches drawn | their blocks hidden | sky cells drawn | diff px |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for c in d["configs"]:
        cull, queue = c["config"].split("_")
        print(f"| {cull} | {queue} | {c['frame_ms']:.1f} | {c['after_frustum']:.0f} | {c['after_occlusion']:.0f} | "
              f"{c['draw_calls']:.0f} | {c['state_changes']:.0f} | {c['occlusion_ms'] + c['query_ms']:.2f} | "
              f"{c['terrain_patches_drawn']:.0f} | {c['terrain_blocks_hidden']:.0f} | {c['sky_cells']:.0f} | "
              f"{c['diff_pixels_max'] if c['config'] not in ('none_naive', 'none_sorted') else '(ref)'} |")
    cfg = {c["config"]: c for c in d["configs"]}
    base, best, gpu = cfg["frustum_sorted"], cfg["occlusion_sorted"], cfg["gpuquery_sorted"]
    print(f"\nocclusion culling (CPU buffer): {base['frame_ms'] / best['frame_ms']:.2f}x faster frames than frustum "
          f"culling alone; GPU occlusion queries: {base['frame_ms'] / gpu['frame_ms']:.2f}x; "
          f"all on: {cfg['none_naive']['frame_ms'] / best['frame_ms']:.2f}x faster than nothing on; draw calls "
          f"{best['draw_calls']:.0f} against {cfg['occlusion_naive']['draw_calls']:.0f} one per object\n")
m = json.load(open(f"{out}/city_mamre.json"))
p = json.load(open(f"{out}/city_mamre_pick.json"))
c = m["city"]; pk = p["pick"]
print("**Mamre** (CityJSON 2.0, EPSG:32734, on its own TINRelief):\n")
print("| buildings | load ms | triangles | frame ms | draw calls | picked pixel | node | osm_id | hit (CRS) |")
print("|---|---|---|---|---|---|---|---|---|")
print(f"| {c['buildings']} | {c['load_ms']:.0f} | {c['triangles']} | {m['draw_ms']:.1f} | {c['draw_calls']} | "
      f"{pk['pixel'][0]:.0f},{pk['pixel'][1]:.0f} | {pk.get('node', '-')} | {pk.get('attributes', {}).get('osm_id', '-')} | "
      f"{pk.get('crs_xy', ['-', '-'])[0]}, {pk.get('crs_xy', ['-', '-'])[1]} |")
PY
cat "$OUT/city.md"
