#!/usr/bin/env bash
# Terrain pyramids as a user runs them: import (one run and GNU parallel jobs,
# byte-identical), info --verify, render and bench streaming with a tiny
# cache, a corrupt tile drawn coarser with a warning, bad input refused.
set -u
HZ="$1"; DATA="$2"; TMP="$3"
mkdir -p "$TMP"; rm -f "$TMP"/*.hzp "$TMP"/*.hzp.part-*
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
json() { python3 -c "import json,sys; d=json.load(open('$1')); print($2)"; }

# A generated terrain, tile by tile.
P="$TMP/gen.hzp"
if $HZ import --generate perlin --size 1025 --seed 7 --out "$P" --quiet --json > "$TMP/gen.json"; then
  ok "import --generate"
else bad "import --generate"; fi
[ "$(json "$TMP/gen.json" "d['samples']")" = 1050625 ] && ok "1025^2 samples" || bad "samples"

# SRTM mosaic with ocean gaps: one run, and 4 GNU parallel jobs + --finish.
S="$DATA/srtm_sierra_coast"
if [ -d "$S" ]; then
  $HZ import "$S" --out "$TMP/sierra.hzp" --quiet --json > "$TMP/sierra.json" && ok "import sierra" || bad "import sierra"
  jobs=$($HZ import "$S" --out "$TMP/sierra2.hzp" --jobs)
  [ "$jobs" -ge 4 ] && ok "sierra splits into $jobs jobs" || bad "jobs: $jobs"
  q=$((jobs / 4))
  ranges="0-$((q-1)) $q-$((2*q-1)) $((2*q))-$((3*q-1)) $((3*q))-$((jobs-1))"
  if parallel -j 2 "$HZ" import "$S" --out "$TMP/sierra2.hzp" --quiet --tiles {} ::: $ranges &&
     $HZ import "$S" --out "$TMP/sierra2.hzp" --finish --quiet; then ok "parallel jobs + finish"
  else bad "parallel jobs"; fi
  cmp -s "$TMP/sierra.hzp" "$TMP/sierra2.hzp" && ok "parallel import byte-identical" || bad "parallel import differs"
  ls "$TMP"/sierra2.hzp.part-* >/dev/null 2>&1 && bad "parts left behind" || ok "parts removed"
  $HZ info "$TMP/sierra.hzp" --verify --json > "$TMP/sinfo.json" && ok "info --verify" || bad "info --verify"
  json "$TMP/sinfo.json" "d[0]['crs']" | grep -q "32610" && ok "CRS UTM 10N" || bad "CRS"
  nd=$(json "$TMP/sinfo.json" "d[0]['nodata_fraction']")
  python3 -c "import sys; sys.exit(0 if 0.05 < $nd < 0.5 else 1)" && ok "ocean gaps are nodata ($nd)" || bad "nodata $nd"
  python3 -c "
import json; d=json.load(open('$TMP/sinfo.json'))[0]; c=d['corners_lonlat']
assert -125.3 < c['nw'][0] < -124.9 and 39.9 < c['nw'][1] < 40.2, c
assert -118.1 < c['se'][0] < -117.5 and 35.8 < c['se'][1] < 36.1, c" && ok "corner lon/lat" || bad "corners"
  $HZ render --terrain "$TMP/sierra.hzp" --out "$TMP/sierra.png" --camera 540000,4200,400000,60,-6 \
     --width 320 --height 180 --json > "$TMP/srender.json" && ok "render --terrain sierra" || bad "render sierra"
  [ "$(json "$TMP/srender.json" "d['terrain_in_view']")" = True ] && ok "sierra in view" || bad "sierra not in view"
  # A near bound on a streamed terrain: fewer triangles, said in the JSON.
  $HZ render --terrain "$TMP/sierra.hzp" --out "$TMP/sierra_near.png" --camera 540000,4200,400000,60,-6 \
     --width 320 --height 180 --near-pixel-error 6 --near-error-distance 2000 --json > "$TMP/snear.json" &&
    python3 -c "
import json; a=json.load(open('$TMP/srender.json')); b=json.load(open('$TMP/snear.json'))
assert b['near_pixel_error'] == 6 and b['near_error_distance'] == 2000 and a['near_pixel_error'] is None, b
assert 0 < b['triangles'] < a['triangles'], (a['triangles'], b['triangles'])
print(a['triangles'], '->', b['triangles'])" && ok "render --terrain --near-pixel-error" || bad "render --terrain --near-pixel-error"
  # The data's east edge (lon -118, padding beyond) at a distance, where coarse tiles draw it: from
  # inside, looking across it, and from outside, along it. Against the same view at a fine pixel
  # error, nothing grows out of the edge into the sky (no wall up, no teeth down): vertices next
  # to the padding morph toward plausible heights, not toward the fill value or the no-data flag.
  for cam in 615000,7000,410000,90,-20 640000,2500,440000,-20,-3; do
    $HZ render --terrain "$TMP/sierra.hzp" --camera $cam --pixel-error 0.3 --out "$TMP/edge_fine.png" >/dev/null &&
    $HZ render --terrain "$TMP/sierra.hzp" --camera $cam --pixel-error 3 --out "$TMP/edge_3.png" >/dev/null &&
    $HZ render --terrain "$TMP/sierra.hzp" --camera $cam --out "$TMP/edge_1.png" >/dev/null &&
    python3 - "$TMP" "$(dirname "$0")" <<'PY' && ok "sierra's edge from $cam: no wall, no teeth" || bad "sierra's edge from $cam"
import sys
sys.path.insert(0, sys.argv[2])
import pngstat
t = sys.argv[1]
w, h, ref = pngstat.read(t + "/edge_fine.png")
jump = lambda p, q: max(abs(p[c] - q[c]) for c in range(3))
def grown(img):
    # pixels that differ from the reference where it shows sky (a smooth gradient) above the
    # terrain, and below it when the view looks at the edge from off the map
    n = 0
    for x in range(w):
        y = 1
        while y < h and jump(ref[y][x], ref[y - 1][x]) <= 6: y += 1
        n += sum(jump(img[k][x], ref[k][x]) > 20 for k in range(0, max(y - 3, 0)))
        if y < h:
            z = h - 2
            while z > y and jump(ref[z][x], ref[z + 1][x]) <= 6: z -= 1
            n += sum(jump(img[k][x], ref[k][x]) > 20 for k in range(min(z + 4, h), h))
    return n
for name in ("edge_3", "edge_1"):
    n = grown(pngstat.read(t + "/" + name + ".png")[2])
    assert n < 300, (name, n)
PY
  done
  # The sea (0 m in the coastal tiles, nodata where tiles are missing) is deep water at 0.1 m; it
  # goes on west of the data, where the coast is sea; it floods no low land (the Central Valley,
  # 0-30 m, from 400 m up). --water-level off draws none.
  sr() { $HZ render --terrain "$TMP/sierra.hzp" --width 320 --height 180 --camera "$@"; }
  if sr 60000,15000,228000,90,-25 --json --out "$TMP/sea.png" > "$TMP/sea.json" &&
     sr 60000,15000,228000,90,-25 --water-level off --out "$TMP/sea_off.png" >/dev/null &&
     sr 20000,3000,228000,330,-10 --out "$TMP/west.png" >/dev/null &&
     sr 20000,3000,228000,330,-10 --water-level off --out "$TMP/west_off.png" >/dev/null &&
     sr 309200,400,221600,135,-8 --out "$TMP/valley.png" >/dev/null &&
     sr 309200,400,221600,135,-8 --water-level off --out "$TMP/valley_off.png" >/dev/null &&
     sr 309200,400,221600,135,-8 --water-level 60 --out "$TMP/valley_60.png" >/dev/null &&
     python3 - "$TMP" "$(dirname "$0")" <<'PY'; then ok "sierra's sea: deep, beyond the data, not over low land"
import json, sys
sys.path.insert(0, sys.argv[2])
import pngstat
t = sys.argv[1]
assert abs(json.load(open(t + "/sea.json"))["water_level"] - 0.1) < 0.05  # heights in steps of 0.067 m
img = lambda n: pngstat.read(t + "/" + n + ".png")[2]
sea = lambda p: p[2] > p[0] and sum(p) < 3 * 110  # dark blue
def share(rows, test, y0, y1):
    cells = [p for r in rows[y0:y1] for p in r]
    return sum(map(test, cells)) / len(cells)
# over the missing tile below the camera: deep sea; without water, the sky colour
assert share(img("sea"), sea, 150, 180) > 0.95, share(img("sea"), sea, 150, 180)
assert share(img("sea_off"), sea, 150, 180) < 0.05
# north-west, beyond the data (away from the sun's glitter): sea
assert share(img("west"), sea, 120, 180) > 0.95, share(img("west"), sea, 120, 180)
assert share(img("west_off"), sea, 120, 180) < 0.05
# the valley: the same picture but for the few channels below 0.1 m
a, b = img("valley"), img("valley_off")
diff = sum(max(abs(p[c] - q[c]) for c in range(3)) > 12 for ra, rb in zip(a, b) for p, q in zip(ra, rb))
print("valley pixels under water:", diff, "of", 320 * 180)
assert diff < 0.01 * 320 * 180, diff  # a lifted plane depth-tested alone floods 8 %
# a level of 60 m does flood it
c = img("valley_60")
diff60 = sum(max(abs(p[k] - q[k]) for k in range(3)) > 12 for rc, rb in zip(c, b) for p, q in zip(rc, rb))
assert diff60 > 2 * diff + 0.1 * 320 * 180, (diff60, diff)
PY
  else bad "sierra's sea"; fi
fi

# The first view of a pyramid is the first view of the same DEM in memory: its highest ground
# (found on the coarse tiles), from the same place.
HD="$DATA/heidelberg_dem_hd_utm32n_25m_float32.tif"
if $HZ import "$HD" --out "$TMP/hd.hzp" --quiet >/dev/null &&
   $HZ render --terrain "$TMP/hd.hzp" --width 320 --height 180 --json --out "$TMP/hdp.png" > "$TMP/hdp.json" &&
   $HZ render --dem "$HD" --effects none --quiet --width 320 --height 180 --json --out "$TMP/hdm.png" > "$TMP/hdm.json" &&
   python3 - "$TMP/hdp.json" "$TMP/hdm.json" <<'PY'
import json, sys
p, m = (json.load(open(f)) for f in sys.argv[1:3])
a, b = p["camera"], m["camera"]
assert all(abs(a[k] - b[k]) < 260 for k in range(3)), (a, b)   # 1 % of the DEM's 26 km
assert abs(a[3] - b[3]) < 5 and abs(a[4] - b[4]) < 3, (a, b)
assert p["terrain_in_view"], p
PY
then ok "pyramid's first view = the DEM's in memory"; else bad "pyramid's first view"; fi

# Streaming under a tiny cache: the flight completes with evictions and no hole.
$HZ bench --terrain "$P" --cache-mb 4 --frames 40 --width 320 --height 180 --json > "$TMP/bench.json" \
  && ok "bench --terrain, 4 MB cache" || bad "bench --terrain"
python3 - "$TMP/bench.json" <<'PY' && ok "bench figures per frame" || bad "bench figures"
import json, sys
d = json.load(open(sys.argv[1]))
f = d["per_frame"]
assert len(f) == 40 and all(x["triangles"] > 0 for x in f), "a frame without terrain"
assert d["tiles_loaded"] > 0 and "late_frame_fraction" in d and d["frame_ms_worst"] >= d["frame_ms_median"]
assert max(x["resident"] for x in f) <= 8 * 8, "more tiles than the cache holds"
PY

# A viewer's flight: --realtime paces frames at --fps on the wall clock. A 3 s path at 10 fps
# takes 3 s (not less: frames ahead of their slot wait), shows the camera at slot times
# (multiples of 0.1 s, rising), and every slot is a frame or a dropped one.
printf 't,x,y,z,yaw,pitch\n0,2000,1500,2000,135,-10\n3,6000,1500,6000,135,-10\n' > "$TMP/p3.csv"
$HZ bench --terrain "$P" --path "$TMP/p3.csv" --realtime --fps 10 --width 320 --height 180 --json > "$TMP/rt.json" \
  && python3 - "$TMP/rt.json" <<'PY' && ok "bench --realtime: paced at 10 fps on the wall clock" || bad "bench --realtime"
import json, sys
d = json.load(open(sys.argv[1]))
f = d["per_frame"]
ts = [x["t"] for x in f]
print("realtime: %d frames, %d dropped, %.2f s" % (d["frames"], d["frames_dropped"], d["flight_seconds"]))
assert d["pacing"] == "realtime" and d["fps"] == 10 and d["path_seconds"] == 3
assert 2.95 <= d["flight_seconds"] < 6.0, d["flight_seconds"]
assert d["frames"] + d["frames_dropped"] == 31, (d["frames"], d["frames_dropped"])
assert all(abs(t * 10 - round(t * 10)) < 1e-4 for t in ts) and ts == sorted(set(ts)) and ts[0] == 0 and ts[-1] <= 3
assert d["nodes_drawn"] == sum(x["nodes"] for x in f) and d["late_nodes"] == sum(x["late_nodes"] for x in f)
PY
# unpaced, the same path flies as fast as frames draw
$HZ bench --terrain "$P" --path "$TMP/p3.csv" --frames 10 --width 320 --height 180 --json > "$TMP/up.json" &&
  [ "$(json "$TMP/up.json" "int(d['pacing'] == 'unpaced' and d['frames'] == 10 and d['flight_seconds'] < 2.5)")" = 1 ] &&
  ok "bench unpaced: 10 frames of the 3 s path in under 2.5 s" || bad "bench unpaced"
expect_fail "--fps without --realtime" "paces a --realtime" $HZ bench --terrain "$P" --fps 30
expect_fail "--realtime with --deterministic" "exclude each other" $HZ bench --terrain "$P" --realtime --deterministic
expect_fail "--deterministic outside bench" "bench options" $HZ render --terrain "$P" --deterministic
expect_fail "bad --water-level" "metres in \\[-1e5, 1e5\\], auto or off" $HZ render --terrain "$P" --water-level deep
expect_fail "absurd --water-level" "auto or off" $HZ render --terrain "$P" --water-level 1e9
# A generated pyramid is no real place: no sea unless asked for.
$HZ render --terrain "$P" --width 64 --height 36 --json --out "$TMP/nw.png" > "$TMP/nw.json" &&
  $HZ render --terrain "$P" --width 64 --height 36 --json --water-level 20 --out "$TMP/w20.png" > "$TMP/w20.json" &&
  [ "$(json "$TMP/nw.json" "d['water_level']")" = None ] && [ "$(json "$TMP/w20.json" "d['water_level']")" = 20.0 ] &&
  ok "no sea on a generated pyramid; --water-level 20 gives one" || bad "water level of a generated pyramid"


# --wrap: an endless map, flown east across two and a half periods.
W="$TMP/wrap.hzp"
$HZ import --generate perlin --size 1025 --seed 3 --wrap --out "$W" --quiet && ok "import --wrap" || bad "import --wrap"
$HZ info "$W" --json | python3 -c "import json,sys; assert json.load(sys.stdin)[0]['size'] == 1025" || bad "wrap info"
$HZ bench --terrain "$W" --frames 40 --width 320 --height 180 --json > "$TMP/wrap.json" && python3 - "$TMP/wrap.json" <<'PY' && ok "endless flight east, terrain in every frame" || bad "wrap flight"
import json, sys
d = json.load(open(sys.argv[1]))
assert all(f["triangles"] > 0 for f in d["per_frame"])
PY
expect_fail "wrap needs a square 2^n+1 DEM" "square" $HZ import "$DATA/N46E008.tif" --wrap --out "$TMP/w2.hzp"

# A flipped byte in a tile: detected, reported, drawn coarser; info --verify fails.
C="$TMP/corrupt.hzp"; cp "$P" "$C"
printf '\x5a' | dd of="$C" bs=1 seek=700 conv=notrunc 2>/dev/null
out=$($HZ info "$C" --verify 2>&1); rc=$?
[ $rc -ne 0 ] && echo "$out" | grep -qi checksum && ok "verify finds the flipped byte" || bad "verify: $rc $out"
out=$($HZ render --terrain "$C" --out "$TMP/corrupt.png" --width 320 --height 180 --camera 100,2500,100,135,-30 2>&1); rc=$?
[ $rc -eq 0 ] && [ -s "$TMP/corrupt.png" ] && ok "corrupt tile still renders (coarser)" || bad "corrupt render: $rc $out"
# Truncated: refused at open.
T="$TMP/trunc.hzp"; head -c 100000 "$P" > "$T"
expect_fail "truncated pyramid" "truncated|size"          $HZ render --terrain "$T" --out "$TMP/t.png"
expect_fail "not a pyramid"     "not a valid|signature"   $HZ render --terrain "$TMP/gen.json" --out "$TMP/t.png"
expect_fail "missing pyramid"   "cannot open"             $HZ render --terrain "$TMP/none.hzp" --out "$TMP/t.png"
expect_fail "out onto terrain"  "overwrite"               $HZ render --terrain "$P" --out "$P"
expect_fail "import onto input" "overwrite"               $HZ import "$P" --out "$P"
expect_fail "bad --tiles"       "expected A-B"            $HZ import --generate perlin --size 1025 --out "$TMP/x.hzp" --tiles 5-2
expect_fail "finish without parts" "missing"              $HZ import --generate perlin --size 4097 --out "$TMP/y.hzp" --finish
expect_fail "diamond windowed"  "only perlin"             $HZ import --generate diamond --size 1025 --out "$TMP/z.hzp"
expect_fail "no inputs"         "no input|required"       $HZ import --out "$TMP/z.hzp"
cmp -s "$P" "$TMP/gen.hzp" && ok "input untouched" || bad "input changed"

echo "$passes passed, $fails failed"
[ $fails -eq 0 ]
