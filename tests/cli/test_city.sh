#!/usr/bin/env bash
# Issue 13 as a user meets it: a real CityJSON city on its own TINRelief and on
# another terrain, picking a known building by its pixel, culling that drops
# nothing visible, the sorted render queue's draw calls, and clean refusals.
set -u
HZ="$1"; DATA="$2"; TMP="$3"
mkdir -p "$TMP"
fails=0; passes=0
ok()   { passes=$((passes+1)); echo "ok   $*"; }
bad()  { fails=$((fails+1)); echo "FAIL $*"; }
expect_fail() {
  local what="$1" re="$2"; shift 2
  local out rc
  out=$("$@" 2>&1 >/dev/null); rc=$?
  if [ $rc -ne 0 ] && [ $rc -lt 128 ] && echo "$out" | grep -Eqi -- "$re"; then ok "$what (exit $rc)"
  else bad "$what: exit $rc, stderr: $out"; fi
}
CITY="$DATA/city/mamre_lod1_epsg32734.city.json"
R="$HZ render --quiet --width 320 --height 180 --effects none"

# ---- the real city on its own TIN, seen from above one building: its pixel picks it
j=$($R --city "$CITY" --camera 1103.5,400,313,0,-89.9 --pick 160,90 --json --out "$TMP/pick.png"); rc=$?
if [ $rc -eq 0 ] && python3 - "$j" <<'PY'
import json, sys
d = json.loads(sys.argv[1]); c = d['city']; p = d['pick']
assert c['buildings'] == 2344 and c['file_crs'] == 'EPSG:32734', c
assert c['clamped'] == 2344 and c['clamp_mean_m'] < 0.5, c   # its TIN shares the buildings' bases
assert c['shadow_caster_samples'] > 2000, c  # the buildings stand on light-map samples (their shadows)
assert d['crs'] == 'EPSG:32734', d['crs']
assert p['hit'] and p['node'] == 'osm_328118446' and p['attributes']['osm_id'] == 328118446, p
x, y = p['crs_xy']
fp = p['attributes']['footprint'][0]
assert min(q[0] for q in fp) <= x <= max(q[0] for q in fp) and min(q[1] for q in fp) <= y <= max(q[1] for q in fp), (x, y)
assert abs(p['world'][1] - 183.28) < 0.5, p['world']      # on its roof (roof_height 183.28)
assert -33.51 < p['lonlat'][1] < -33.50 and 18.47 < p['lonlat'][0] < 18.48, p['lonlat']
PY
then ok "mamre: 2344 buildings on their TIN, pixel picks osm_328118446"; else bad "mamre pick (exit $rc): $j"; fi

# ---- picks agree with the image at the building's edges: the pixels on either side of
# its left and right edges, on three rows, pick it exactly when they show its roof
if python3 - "$HZ" "$CITY" "$TMP" "$(dirname "$0")" <<'PY'
import json, subprocess, sys
hz, city, tmp = sys.argv[1:4]
sys.path.insert(0, sys.argv[4])
import pngstat
base = [hz, "render", "--quiet", "--width", "320", "--height", "180", "--effects", "none", "--city", city,
        "--camera", "1103.5,400,313,0,-89.9", "--json", "--out", tmp + "/edge.png"]
def pick(x, y):
    p = json.loads(subprocess.run(base + ["--pick", "%d,%d" % (x, y)], check=True, capture_output=True, text=True).stdout)["pick"]
    assert p["pixel"] == [x, y], p
    return p.get("node")
subprocess.run(base, check=True, capture_output=True)
w, h, rows = pngstat.read(tmp + "/edge.png")
roof = lambda x, y: rows[y][x][0] > rows[y][x][1] + 20   # red roofs on green ground
checked = 0
for y in (87, 90, 93):
    assert roof(160, y), (y, rows[y][160])
    x0 = 160
    while roof(x0 - 1, y): x0 -= 1
    x1 = 160
    while roof(x1 + 1, y): x1 += 1
    for x, inside in ((x0, True), (x1, True), (x0 - 1, False), (x1 + 1, False)):
        n = pick(x, y)
        assert (n == "osm_328118446") == inside, (x, y, inside, n)
        checked += 1
assert checked == 12
PY
then ok "picks agree with the image on both sides of a building's edges"; else bad "picks at the building's edges"; fi

expect_fail "pick outside the image" "outside the 320x180 image" $R --size 257 --pick 320,10

# ---- the same city as a CityJSON Text Sequence (.city.jsonl: a header line, then one
# CityJSONFeature per building with its own vertices): same buildings, triangles, pick
python3 - "$CITY" "$TMP/mamre.city.jsonl" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
objs, verts = d["CityObjects"], d["vertices"]
head = {k: v for k, v in d.items() if k not in ("CityObjects", "vertices")}
head["CityObjects"], head["vertices"] = {}, []
def remap(b, m, local):
    if isinstance(b, list):
        return [remap(x, m, local) for x in b]
    if b not in m:
        m[b] = len(local)
        local.append(verts[b])
    return m[b]
with open(sys.argv[2], "w") as f:
    f.write(json.dumps(head) + "\n")
    for oid, o in objs.items():
        if o.get("parents"):
            continue
        group = [oid] + o.get("children", [])
        m, local, out = {}, [], {}
        for gid in group:
            g = dict(objs[gid])
            g["geometry"] = [dict(x, boundaries=remap(x["boundaries"], m, local)) for x in g.get("geometry", [])]
            out[gid] = g
        f.write(json.dumps({"type": "CityJSONFeature", "id": oid, "CityObjects": out, "vertices": local}) + "\n")
PY
j1=$($R --city "$CITY" --camera 1103.5,400,313,0,-89.9 --pick 160,90 --json --out "$TMP/pickf.png"); r1=$?
j2=$($R --city "$TMP/mamre.city.jsonl" --camera 1103.5,400,313,0,-89.9 --pick 160,90 --json --out "$TMP/picks.png"); r2=$?
if [ $r1 -eq 0 ] && [ $r2 -eq 0 ] && python3 - "$j1" "$j2" <<'PY'
import json, sys
a, b = json.loads(sys.argv[1]), json.loads(sys.argv[2])
ca, cb = a['city'], b['city']
for k in ('buildings', 'triangles', 'clamped', 'file_crs'):
    assert ca[k] == cb[k], (k, ca[k], cb[k])
assert cb['features'] > 2000 and ca['features'] == 0, (ca['features'], cb['features'])
assert b['pick']['node'] == a['pick']['node'] == 'osm_328118446', b['pick']
assert all(abs(x - y) < 1e-3 for x, y in zip(a['pick']['crs_xy'], b['pick']['crs_xy'])), (a['pick'], b['pick'])
PY
then ok "mamre as a CityJSON Text Sequence: the same $(echo "$j2" | python3 -c "import json,sys;print(json.load(sys.stdin)['city']['features'])") features' buildings, triangles and pick"
else bad "mamre sequence (exit $r1 $r2): $j2"; fi

# ---- picking the terrain: the hit lies on the surface, between buildings
j=$($R --city "$CITY" --camera 1300,400,600,0,-89.9 --pick 10,10 --json --out "$TMP/pick2.png"); rc=$?
if [ $rc -eq 0 ] && python3 - "$j" <<'PY'
import json, sys
p = json.loads(sys.argv[1])['pick']
assert p['hit'] and p['what'] in ('terrain', 'node'), p
assert 140 < p['world'][1] < 260, p
PY
then ok "pick over the city returns a world position"; else bad "pick 2 (exit $rc): $j"; fi

# ---- street level: occlusion drops most objects and no pixel changes
S="--city $CITY --camera 1400,188,900,-60,0"
j1=$($R $S --cull occlusion --json --out "$TMP/occ.png"); r1=$?
j2=$($R $S --cull none --json --out "$TMP/none.png"); r2=$?
j3=$($R $S --cull frustum --draw naive --json --out "$TMP/naive.png"); r3=$?
if [ $r1 -eq 0 ] && [ $r2 -eq 0 ] && [ $r3 -eq 0 ] && python3 - "$j1" "$j2" "$j3" <<'PY'
import json, sys
a, b, n = (json.loads(s)['city'] for s in sys.argv[1:4])
assert a['after_occlusion'] * 3 < a['after_frustum'] < a['scene_objects'], a
assert b['after_occlusion'] == b['scene_objects'] == 4688, b
# sorted: one multi-draw per shader, the materials' colours coming with the
# instances; naive: one draw per object, and no material state either
assert a['draw_calls'] == 1 and n['draw_calls'] == n['after_occlusion'] == n['after_frustum'], (a, n)
assert n['state_changes'] == a['state_changes'] <= 3, (a, n)
# the terrain's patches behind the buildings are not drawn either (the images below stay equal):
# most of them, each tested with its own samples' heights (57 of 149; with its great-grandparent
# node's heights, 91)
assert a['terrain_patches_drawn'] < a['terrain_patches'] == b['terrain_patches'] == b['terrain_patches_drawn'], (a, b)
assert a['terrain_patches_drawn'] * 2 < a['terrain_patches'], a
# the terrain's occluders: one quad for every cell with data within reach (taken ring by ring)
assert a['terrain_occluders'] == a['terrain_window_cells'] > 100, a
assert b['terrain_occluders'] == b['terrain_window_cells'] == 0, b
print("terrain patches drawn: %d of %d" % (a['terrain_patches_drawn'], a['terrain_patches']), file=sys.stderr)
PY
then ok "street level: occlusion culls $(echo "$j1" | python3 -c "import json,sys;c=json.load(sys.stdin)['city'];print(c['after_frustum']-c['after_occlusion'])") objects, sorted queue 1 draw"
else bad "street culling (exit $r1 $r2 $r3)"; fi
cmp -s "$TMP/occ.png" "$TMP/none.png" && ok "occlusion + frustum culled image == unculled image" \
  || bad "culling changed the image"
cmp -s "$TMP/naive.png" "$TMP/none.png" && ok "naive draw order gives the same image" || bad "naive image differs"
# A little higher, looking down over the roofs: buildings seen against the
# ground, where a culling test that is not conservative shows (an extra 100 m
# of slack in the depth comparison changes this image).
O="--city $CITY --camera 1400,195,900,-60,-6"
$R $O --cull occlusion --out "$TMP/occ2.png" >/dev/null && $R $O --cull none --out "$TMP/none2.png" >/dev/null &&
  cmp -s "$TMP/occ2.png" "$TMP/none2.png" && ok "over the roofs: culled image == unculled image"   || bad "culling changed the image over the roofs"

# ---- on another terrain without a georeference: centred and clamped
j=$($R --city "$CITY" --generate perlin --size 513 --json --out "$TMP/gen.png"); rc=$?
if [ $rc -eq 0 ] && python3 - "$j" <<'PY'
import json, sys
c = json.loads(sys.argv[1])['city']
assert c['clamped'] == 2344 and c['without_ground'] == 0, c
PY
then ok "city on a generated terrain: every building clamped"; else bad "city on generated (exit $rc)"; fi

# ---- OGR footprints in lon/lat on the georeferenced Heidelberg DEM (UTM 32N): extruded,
# clamped, and the big one picked by its pixel
cat > "$TMP/hd.geojson" <<'GJ'
{"type":"FeatureCollection","features":[
{"type":"Feature","properties":{"osm_id":4711,"height":15,"name":"test hall"},"geometry":{"type":"Polygon","coordinates":[[[8.69,49.41],[8.6903,49.41],[8.6903,49.4102],[8.69,49.4102],[8.69,49.41]]]}},
{"type":"Feature","properties":{"osm_id":4712,"building:levels":"3"},"geometry":{"type":"Polygon","coordinates":[[[8.6906,49.41],[8.6908,49.41],[8.6908,49.4101],[8.6906,49.4101],[8.6906,49.41]]]}}]}
GJ
j=$($HZ render --quiet --effects none --dem "$DATA/heidelberg_dem_hd_utm32n_25m_float32.tif" --footprints "$TMP/hd.geojson" \
     --pick 540,300 --json --out "$TMP/fp.png"); rc=$?
if [ $rc -eq 0 ] && python3 - "$j" <<'PY'
import json, sys
d = json.loads(sys.argv[1]); f = d['city']['footprints']; p = d['pick']
assert f['buildings'] == 2 and f['clamped'] == 2 and f['crs'] == 'EPSG:32632', f
assert f['height_from_field'] == 1 and f['height_from_levels'] == 1 and f['height_default'] == 0, f
assert p['node'] == '4711' and p['attributes']['osm_id'] == 4711 and p['attributes']['extruded_height'] == 15, p
lon, lat = p['lonlat']
assert 8.69 - 1e-5 <= lon <= 8.6903 + 1e-5 and 49.41 - 1e-5 <= lat <= 49.4102 + 1e-5, p['lonlat']
PY
then ok "footprints extruded on heidelberg, pixel picks osm_id 4711"; else bad "footprints (exit $rc): $j"; fi
# A height field named on the command line; a name no layer has is refused with the fields.
j=$($HZ render --quiet --effects none --dem "$DATA/heidelberg_dem_hd_utm32n_25m_float32.tif" --footprints "$TMP/hd.geojson" \
     --height-field osm_id --width 160 --height 90 --json --out "$TMP/fp2.png"); rc=$?
if [ $rc -eq 0 ] && echo "$j" | python3 -c "
import json, sys
f = json.load(sys.stdin)['city']['footprints']
assert f['height_from_field'] == 2 and f['height_field'] == 'osm_id', f"
then ok "--height-field osm_id: both buildings take it"; else bad "--height-field (exit $rc): $j"; fi
expect_fail "--height-field typo"     "has no field 'hieght' \\(its fields: "  $R --dem "$DATA/heidelberg_dem_hd_utm32n_25m_float32.tif" \
  --footprints "$TMP/hd.geojson" --height-field hieght
expect_fail "footprints not vector"   "not a vector file"        $R --generate perlin --size 257 --footprints "$DATA/PROVENANCE.md"

# ---- horizon city: a procedural city as a scene file, rendered with instancing
out=$($HZ city --blocks 3 --generate perlin --size 513 --seed 4 --out "$TMP/c3.json"); rc=$?
j=$($R --scene "$TMP/c3.json" --json --out "$TMP/c3.png"); rc2=$?
if [ $rc -eq 0 ] && [ $rc2 -eq 0 ] && python3 - "$TMP/c3.json" "$j" <<'PY'
import json, sys
sc = json.load(open(sys.argv[1])); d = json.loads(sys.argv[2]); c = d['city']
blocks = sc['nodes'][0]['children']
n = sum(len(b['children']) for b in blocks)
assert len(blocks) == 9 and 150 < n < 250, (len(blocks), n)
assert sc['terrain'] == {'generate': 'perlin', 'size': 513, 'seed': 4}, sc['terrain']
assert c['scene_file']['objects'] == n and c['scene_file']['clamped'] == n and c['meshes'] == 1, c
assert c['draw_calls'] == 1 and c['queue_items'] == 1, c   # one box mesh, instanced, colours per instance
PY
then ok "horizon city: 9 blocks written, rendered in 1 instanced draw"; else bad "horizon city (exit $rc $rc2): $out $j"; fi
# Steep ground: lots on a cliff stay empty (the default 45 degrees), all built with --max-slope 90
o45=$($HZ city --blocks 3 --generate perlin --size 513 --seed 4 --out "$TMP/c3s.json")
o90=$($HZ city --blocks 3 --generate perlin --size 513 --seed 4 --max-slope 90 --out "$TMP/c3a.json")
if python3 - "$TMP/c3s.json" "$TMP/c3a.json" "$o45" <<'PY'
import json, sys
def names(p):  # the lots, by place and size
    return {(tuple(n['position']), tuple(n['scale'])) for b in json.load(open(p))['nodes'][0]['children']
            for n in b['children']}
steep, every = names(sys.argv[1]), names(sys.argv[2])
empty = int(sys.argv[3].split('steep ground')[1].split()[0])
# the same city with the steep lots left out: nothing added, nothing else changed
assert steep < every and len(every) - len(steep) == empty > 0, (len(steep), len(every), empty)
PY
then ok "horizon city leaves lots on steep ground empty"; else bad "city --max-slope: $o45"; fi
expect_fail "city --max-slope 100"    "--max-slope wants degrees" $HZ city --blocks 2 --max-slope 100 --out "$TMP/x.json"
expect_fail "city without --blocks"   "give --blocks"            $HZ city --generate perlin --size 257 --out "$TMP/x.json"
expect_fail "city --blocks 0"         "--blocks wants"           $HZ city --blocks 0 --out "$TMP/x.json"
printf '{"nodes": [{"model": "tower"}]}' > "$TMP/badmodel.json"
expect_fail "scene unknown model"     "badmodel.json: nodes\[0\].model: unknown model \"tower\"" \
  $R --generate perlin --size 257 --scene "$TMP/badmodel.json"
printf '{"nodes": [{"name": "a", "crs": [1, 2, 3]}]}' > "$TMP/crsnogeo.json"
expect_fail "scene crs without georef" "nodes\[0\].crs: needs a terrain with a georeference" \
  $R --generate perlin --size 257 --scene "$TMP/crsnogeo.json"
expect_fail "--city-bench without objects" "need --city or --scene" $R --generate perlin --size 257 --city-bench street
# --city-bench: every stage's figures, the culled frames equal to the unculled
# ones, and the path's last frame (every stage on) written to --out
j=$($R --scene "$TMP/c3.json" --city-bench overview --city-bench-frames 2 --json --out "$TMP/c3bench.png"); rc=$?
if [ $rc -eq 0 ] && python3 - "$TMP/c3bench.png" "$j" "$(dirname "$0")" <<'PY'
import json, sys
sys.path.insert(0, sys.argv[3])
import pngstat
w, h, rows = pngstat.read(sys.argv[1])
assert (w, h) == (320, 180), (w, h)
assert len({tuple(p) for r in rows for p in r}) > 20, "a flat image"
d = json.loads(sys.argv[2])
c = {x["config"]: x for x in d["configs"]}
assert c["occlusion_sorted"]["diff_pixels_max"] == 0 and c["frustum_sorted"]["diff_pixels_max"] == 0, c
PY
then ok "--city-bench writes its figures and the last frame"; else bad "--city-bench (exit $rc): $j"; fi
# with every effect, motion blur included: each configuration blurs with its
# own frames, so the culled ones still equal the unculled
j=$($HZ render --quiet --width 320 --height 180 --effects all --scene "$TMP/c3.json" --city-bench street \
    --city-bench-frames 3 --json --out "$TMP/c3fx.png"); rc=$?
if [ $rc -eq 0 ] && python3 - "$j" <<'PY'
import json, sys
c = {x["config"]: x for x in json.loads(sys.argv[1])["configs"]}
for k in ("frustum_naive", "frustum_sorted", "occlusion_naive", "occlusion_sorted"):
    assert c[k]["diff_pixels_max"] == 0, (k, c[k])
PY
then ok "--city-bench --effects all: culled frames equal to the unculled"; else bad "--city-bench --effects all (exit $rc): $j"; fi

# ---- a forest over the city: no tree is planted where a building stands; the
# planting goes around the buildings instead of losing the trees (2000 asked,
# centred on the city; small trees in a cache of the test's own)
out=$($HZ render --width 320 --height 180 --scene "$TMP/c3.json" --forest 2000 --forest-at 2560,2560 \
      --forest-leaves 600 --tree-cache "$TMP/trees" --forest-save "$TMP/c3f.csv" --json --out "$TMP/c3f.png" 2>&1 >"$TMP/c3f.json"); rc=$?
if [ $rc -eq 0 ] && python3 - "$TMP/c3.json" "$TMP/c3f.csv" "$TMP/c3f.json" <<'PY'
import json, math, sys
sc = json.load(open(sys.argv[1])); city = sc['nodes'][0]; cx, _, cz = city['position']
boxes = []  # unit boxes scaled, turned by yaw about y, standing at position
for b in city['children']:
    for o in b['children']:
        px, _, pz = o['position']; sx, _, sz = o['scale']; a = math.radians(o.get('yaw', 0.0))
        boxes.append((cx + px, cz + pz, sx / 2, sz / 2, a))
trees = [tuple(map(float, l.split(',')[:2])) for l in open(sys.argv[2]) if not l.startswith('#')]
n = json.load(open(sys.argv[3]))['forest_trees']
assert n == len(trees) and n >= 1950, (n, len(trees))
def gap(x, z, b):  # distance outside the footprint (negative inside), either sense of yaw
    X, Z, hx, hz, a = b; dx, dz = x - X, z - Z; c, s = math.cos(a), math.sin(a)
    return min(max(abs(dx * c - dz * s) - hx, abs(dx * s + dz * c) - hz),
               max(abs(dx * c + dz * s) - hx, abs(-dx * s + dz * c) - hz))
inside = [(x, z) for x, z in trees if any(gap(x, z, b) < 1.0 for b in boxes)]
near = sum(1 for x, z in trees if any(gap(x, z, b) < 30.0 for b in boxes))
assert not inside, inside[:5]
assert near > 200, near  # the trees do stand among the buildings
PY
then ok "forest over the city: $(grep -c -v '^#' "$TMP/c3f.csv") trees, none on a building"
else bad "forest over the city (exit $rc): $out"; fi

# ---- shadows on the objects' faces: a 60 m block east of a 10 m box, the sun
# in the east 30 degrees up. The box's east face (at the image centre) is in
# the block's shade; with the block far away the same face is in the sun (so
# the box does not shade itself).
for bx in 530 900; do
  cat > "$TMP/shade_$bx.json" <<EOF
{"terrain": {"generate": "perlin", "size": 129, "seed": 1, "amplitude": 1, "spacing": 10},
 "lights": {"sun": [90, 30]},
 "materials": {"white": {"color": [0.8, 0.8, 0.8]}},
 "models": {"a": {"box": [10, 10, 10], "material": "white"}, "b": {"box": [10, 60, 30], "material": "white"}},
 "nodes": [{"name": "A", "model": "a", "position": [500, 0, 500], "clamp": "ground"},
           {"name": "B", "model": "b", "position": [$bx, 0, 500], "clamp": "ground"}]}
EOF
done
V="--width 320 --height 180 --camera 540,15,440,210.3,-8.2 --pick 160,90 --json"
j1=$($HZ render --quiet --effects shadows --scene "$TMP/shade_530.json" $V --out "$TMP/shade_530.png"); r1=$?
j2=$($HZ render --quiet --effects shadows --scene "$TMP/shade_900.json" $V --out "$TMP/shade_900.png"); r2=$?
if [ $r1 -eq 0 ] && [ $r2 -eq 0 ] && python3 - "$j1" "$j2" "$TMP" "$(dirname "$0")" <<'PY'
import json, sys
sys.path.insert(0, sys.argv[4])
import pngstat
for s in sys.argv[1:3]:
    assert json.loads(s)['pick']['node'] == 'A', s
def lum(path):
    w, h, rows = pngstat.read(path)
    px = [rows[y][x] for y in range(86, 95) for x in range(156, 165)]  # the box's east face
    return sum(0.299 * r + 0.587 * g + 0.114 * b for r, g, b in px) / len(px)
shade, sun = lum(sys.argv[3] + "/shade_530.png"), lum(sys.argv[3] + "/shade_900.png")
print("east face: %.1f in the block's shade, %.1f in the sun" % (shade, sun), file=sys.stderr)
assert sun > 1.6 * shade, (shade, sun)
PY
then ok "a block's shade falls on the box's face; alone the face is in the sun"
else bad "shadows on faces (exit $r1 $r2)"; fi

# A tall box alone under a low north-east sun: its sunlit north face is not
# shaded by the box's own samples (which its roof raises): it looks as
# without shadows. (Looked up in place instead of one sample outward, the
# face's lower half falls into the box's own shade.)
cat > "$TMP/alone.json" <<'EOF'
{"terrain": {"generate": "perlin", "size": 129, "seed": 1, "amplitude": 1, "spacing": 10},
 "lights": {"sun": [60, 10]},
 "materials": {"white": {"color": [0.8, 0.8, 0.8]}},
 "models": {"a": {"box": [30, 40, 30], "material": "white"}},
 "nodes": [{"name": "A", "model": "a", "position": [500, 0, 500], "clamp": "ground"}]}
EOF
V="--width 320 --height 180 --camera 500,6,430,180,-2"
if $HZ render --quiet --effects shadows --scene "$TMP/alone.json" $V --out "$TMP/alone_sh.png" >/dev/null &&
   $HZ render --quiet --effects none --scene "$TMP/alone.json" $V --out "$TMP/alone_none.png" >/dev/null &&
   python3 - "$TMP" "$(dirname "$0")" <<'PY'
import sys
sys.path.insert(0, sys.argv[2])
import pngstat
def lum(path):
    w, h, rows = pngstat.read(path)
    px = [rows[y][x] for y in range(85, 96) for x in range(150, 170)]  # the north face
    return sum(0.299 * r + 0.587 * g + 0.114 * b for r, g, b in px) / len(px)
a, b = lum(sys.argv[1] + "/alone_sh.png"), lum(sys.argv[1] + "/alone_none.png")
print("north face alone: %.1f with shadows, %.1f without" % (a, b), file=sys.stderr)
assert abs(a - b) <= 0.03 * b, (a, b)
PY
then ok "an object does not shade its own sunlit face"; else bad "self-shading of a face"; fi

# ---- an open mesh (one quad, an OBJ) seen from behind is not drawn (back
# faces are culled), so it hides nothing: the box behind it stays, and the
# image with occlusion culling equals the unculled one. A closed wall in
# front of the same camera still hides the box behind it.
printf 'v -20 0 0\nv 20 0 0\nv 20 30 0\nv -20 30 0\nf 1 2 3 4\n' > "$TMP/quad.obj"
cat > "$TMP/open.json" <<EOF
{"terrain": {"generate": "perlin", "size": 129, "seed": 1, "amplitude": 1, "spacing": 10},
 "materials": {"red": {"color": [0.9, 0.1, 0.1]}, "white": {"color": [0.8, 0.8, 0.8]}},
 "models": {"quad": {"file": "$TMP/quad.obj", "material": "white"}, "box": {"box": [8, 8, 8], "material": "red"},
            "wall": {"box": [40, 30, 2], "material": "white"}},
 "nodes": [{"name": "Q", "model": "quad", "position": [500, 0, 500], "clamp": "ground"},
           {"name": "B", "model": "box", "position": [500, 0, 560], "clamp": "ground"},
           {"name": "W", "model": "wall", "position": [800, 0, 500], "clamp": "ground"},
           {"name": "C", "model": "box", "position": [800, 0, 560], "clamp": "ground"}]}
EOF
V="--width 320 --height 180 --camera 500,8,400,180,0 --json"
W="--width 320 --height 180 --camera 800,8,400,180,0 --json"
j1=$($R --scene "$TMP/open.json" $V --cull occlusion --out "$TMP/open_occ.png"); r1=$?
j2=$($R --scene "$TMP/open.json" $V --cull none --out "$TMP/open_none.png"); r2=$?
j3=$($R --scene "$TMP/open.json" $W --cull occlusion --out "$TMP/closed_occ.png"); r3=$?
if [ $r1 -eq 0 ] && [ $r2 -eq 0 ] && [ $r3 -eq 0 ] && cmp -s "$TMP/open_occ.png" "$TMP/open_none.png" &&
   python3 - "$j1" "$j3" <<'PY'
import json, sys
a, c = (json.loads(s)['city'] for s in sys.argv[1:3])
assert a['after_occlusion'] == a['after_frustum'] >= 2, a  # the open quad hid nothing
assert c['after_occlusion'] < c['after_frustum'], c        # the closed wall hides its box
PY
then ok "an open mesh's back face hides nothing; a closed one's front hides"
else bad "open mesh occlusion (exit $r1 $r2 $r3): $j1 $j3"; fi
# From inside a closed box every face is a back face: not drawn, the eye sees
# through them, so they must hide nothing either (the box behind the room's
# far wall stays).
cat > "$TMP/room.json" <<EOF
{"terrain": {"generate": "perlin", "size": 129, "seed": 1, "amplitude": 1, "spacing": 10},
 "materials": {"red": {"color": [0.9, 0.1, 0.1]}, "white": {"color": [0.8, 0.8, 0.8]}},
 "models": {"room": {"box": [60, 30, 60], "material": "white"}, "box": {"box": [8, 8, 8], "material": "red"}},
 "nodes": [{"name": "R", "model": "room", "position": [500, 0, 500], "clamp": "ground"},
           {"name": "B", "model": "box", "position": [500, 0, 600], "clamp": "ground"}]}
EOF
# hides_nothing SCENE NAME CAMERA WHAT: $TMP/SCENE.json seen from CAMERA,
# with occlusion culling and without: the same image, and every object in
# view drawn.
hides_nothing() {
  local scene="$TMP/$1.json" name="$2" cam="$3" what="$4" ja jb ra rb
  ja=$($R --scene "$scene" --width 320 --height 180 --camera "$cam" --json --cull occlusion \
       --out "$TMP/${name}_occ.png"); ra=$?
  jb=$($R --scene "$scene" --width 320 --height 180 --camera "$cam" --json --cull none \
       --out "$TMP/${name}_none.png"); rb=$?
  if [ $ra -eq 0 ] && [ $rb -eq 0 ] && cmp -s "$TMP/${name}_occ.png" "$TMP/${name}_none.png" &&
     python3 -c "import json,sys;a=json.loads(sys.argv[1])['city'];assert a['after_occlusion']==a['after_frustum']>=1,a" "$ja"
  then ok "$what"; else bad "$what (exit $ra $rb): $ja"; fi
}
hides_nothing room room 500,6,480,180,0 "from inside a closed box its faces hide nothing"
# From under the ground, looking up through it (the renderer culls the
# terrain seen from below) at the boxes standing on it: the ground hides nothing.
hides_nothing room under 500,-30,400,180,16 "from under the ground the terrain hides nothing"
# The ground's occluder quads lie under its surface (each corner at the
# lowest sample around it, less a metre): 40 m lower on this 45 degree slope.
# An eye 2 m inside the slope is above them but under the ground, which it
# sees through from below: looking down past the cliff at the box in the
# valley, the quads ahead would hide it.
# cliff.asc: along z, a valley floor at 0 m, a 500 m cliff at z = 410, then
# the slope rising 1 m per metre. hole.asc: flat ground, no data (a sea gap)
# for 900 <= z < 1000, and beyond it a slope falling from 300 m at its edge
# to 0 at z = 600. From the near shore at 10 m the eye looks across the gap
# under that slope's edge and sees its underside (which the renderer culls):
# the box behind it shows.
python3 - "$TMP" <<'PY'
import sys
for name, height in (("cliff", lambda z: 0 if z < 410 else 500 + (z - 410)),
                     ("hole", lambda z: -9999 if 900 <= z < 1000 else (z - 600 if 600 <= z < 900 else 0))):
    rows = [" ".join(["%.1f" % height(j * 10)] * 129) for j in range(129)]
    with open(f"{sys.argv[1]}/{name}.asc", "w") as f:
        f.write("ncols 129\nnrows 129\nxllcorner 0\nyllcorner 0\ncellsize 10\nNODATA_value -9999\n")
        f.write("\n".join(rows) + "\n")
PY
# box_scene NAME TERRAIN SIDE X Z: $TMP/NAME.json, the terrain (a JSON
# object) with one red box A of SIDE metres standing on it at X, Z.
box_scene() {
  cat > "$TMP/$1.json" <<EOF
{"terrain": $2,
 "materials": {"red": {"color": [0.9, 0.1, 0.1]}},
 "models": {"a": {"box": [$3, $3, $3], "material": "red"}},
 "nodes": [{"name": "A", "model": "a", "position": [$4, 0, $5], "clamp": "ground"}]}
EOF
}
box_scene cliff '{"dem": "cliff.asc", "spacing": 10}' 40 640 200
box_scene hole '{"dem": "hole.asc", "spacing": 10}' 40 640 300
hides_nothing cliff cliff 640,688,600,0,-59 "from inside a slope, over its occluder quads, the ground hides nothing"
hides_nothing hole hole 640,10,1040,0,1 "across a gap without data the underside of the ground beyond hides nothing"
# On a fine DEM (1 m, as lidar grids) the ground's occluder cells span at
# least 60 m, not 4 samples: within the 3 km reach at most about 10 000 quads
# (4-sample cells put 198 000 of this 2 km map into the buffer, 57 ms a frame),
# and the culled image still equals the unculled one (the box in the middle).
box_scene fine '{"generate": "perlin", "size": 2049, "seed": 1, "amplitude": 1, "spacing": 1}' 40 1000 900
hides_nothing fine fine 1000,300,1100,0,-56 "a 1 m DEM: the culled image equals the unculled one"
python3 -c "import json,sys;a=json.loads(sys.argv[1])['city'];assert 100<a['occluder_quads']<=10500,a" \
  "$($R --scene "$TMP/fine.json" --width 320 --height 180 --camera 1000,300,1100,0,-56 --json --out "$TMP/fine_q.png")" &&
  ok "a 1 m DEM: the ground occludes with at most about 10 000 quads" || bad "a 1 m DEM's occluder quads"

# ---- fog: a red box 2 km away melts into the horizon with the fog effect
# (its height fog too, as the ground around it), and stands out without it
box_scene fogbox '{"generate": "perlin", "size": 257, "seed": 1, "amplitude": 1, "spacing": 10}' 40 2100 1280
# box_vs_horizon NAME MAX_ON MIN_OFF ARGS...: renders ARGS with the fog effect
# and without it; the box A is picked at 640,357 in both, and its pixel lies
# at most MAX_ON levels from the horizon just above it with the effect, at
# least MIN_OFF without.
box_vs_horizon() {
  local name=$1 max_on=$2 min_off=$3 j1 j2 r1 r2
  shift 3
  local view=(--camera 100,20,1280,90,0 --pick 640,357 --json)
  j1=$($HZ render --quiet --effects fog "$@" "${view[@]}" --out "$TMP/${name}_on.png"); r1=$?
  j2=$($HZ render --quiet --effects none "$@" "${view[@]}" --out "$TMP/${name}_off.png"); r2=$?
  [ $r1 -eq 0 ] && [ $r2 -eq 0 ] && python3 - "$j1" "$j2" "$TMP/$name" "$(dirname "$0")" "$max_on" "$min_off" <<'PY'
import json, sys
sys.path.insert(0, sys.argv[4])
import pngstat
for s in sys.argv[1:3]:
    assert json.loads(s)['pick']['node'] == 'A', s
def gap(path):  # the box's pixel against the horizon just above it
    w, h, rows = pngstat.read(path)
    return max(abs(a - b) for a, b in zip(rows[357][640], rows[340][640]))
on, off = gap(sys.argv[3] + "_on.png"), gap(sys.argv[3] + "_off.png")
print("%s: box %d levels from the horizon with the fog effect, %d without" % (sys.argv[3].split("/")[-1], on, off),
      file=sys.stderr)
assert on <= int(sys.argv[5]) and off >= int(sys.argv[6]), (on, off)
PY
}
if box_vs_horizon fog 20 40 --scene "$TMP/fogbox.json" --fog 0.0005
then ok "a far box is fogged as the ground with the fog effect"; else bad "fog on objects"; fi

# ---- the fog effect's fade over the last fifth of the view distance: a box
# at 97 % of it is nearly the sky (fog itself too thin to matter), and
# stands out without the effect
sed 's/"position": \[2100, 0, 1280\]/"position": [2300, 0, 1280]/' "$TMP/fogbox.json" > "$TMP/fadebox.json"
if box_vs_horizon fade 25 100 --scene "$TMP/fadebox.json" --fog 1e-7 --far 2250
then ok "a box at the end of the view fades into the sky with the fog effect"; else bad "far fade on objects"; fi

# ---- refusals
printf '{"type":"CityJSON","version":"2.0","CityObjects":{},"vertices":[]}' > "$TMP/notransform.city.json"
expect_fail "city without transform"  "transform: missing"       $R --city "$TMP/notransform.city.json"
printf '{"type":"CityJSON",' > "$TMP/trunc.city.json"
expect_fail "truncated city"          "line 1"                   $R --city "$TMP/trunc.city.json"
python3 - "$TMP/badidx.city.json" <<'PY'
import json, sys
json.dump({"type": "CityJSON", "version": "2.0", "transform": {"scale": [1, 1, 1], "translate": [0, 0, 0]},
           "metadata": {"referenceSystem": "https://www.opengis.net/def/crs/EPSG/0/32734"},
           "CityObjects": {"b": {"type": "Building", "geometry": [{"type": "MultiSurface", "lod": "1",
                           "boundaries": [[[0, 1, 7]]]}]}},
           "vertices": [[0, 0, 0], [1, 0, 0], [1, 1, 0]]}, open(sys.argv[1], 'w'))
PY
expect_fail "city bad vertex index"   "CityObjects.b.geometry\[0\].boundaries\[0\]: ring 0, entry 2: vertex 7 out of range" \
  $R --city "$TMP/badidx.city.json"
sed 's/32734/999999/' "$TMP/badidx.city.json" > "$TMP/badcrs.city.json"
expect_fail "city unknown CRS"        "unknown CRS EPSG:999999"  $R --city "$TMP/badcrs.city.json"
expect_fail "city missing file"       "no such file"             $R --city "$TMP/none.city.json"
expect_fail "bad --pick"              "--pick wants"             $R --generate perlin --size 257 --pick 1
expect_fail "bad --cull"              "--cull wants"             $R --generate perlin --size 257 --cull some
expect_fail "bad --draw"              "--draw wants"             $R --generate perlin --size 257 --draw fast

echo "$passes passed, $fails failed"
[ $fails -eq 0 ]
