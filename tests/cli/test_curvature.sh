#!/usr/bin/env bash
# --curvature on|off|auto as a user runs it (run under scripts/with-xvfb.sh for
# `horizon view`): auto switches at 50 km of terrain, the JSON says what was
# used (render, bench, view, and the streamed --terrain render and bench), the
# Sierra mosaic gets the WGS84 radius at its latitude and its edge drop, a high
# view of it shows more sky with curvature on (the far terrain sinks), and bad
# values are refused.
set -u
HZ="$1"; DATA="$2"; TMP="$3"; HERE="$(cd "$(dirname "$0")" && pwd)"
mkdir -p "$TMP"
fails=0; passes=0
ok()  { passes=$((passes+1)); echo "ok   $*"; }
bad() { fails=$((fails+1)); echo "FAIL $*"; }

# judge "what" JSON 'python expression over j'
judge() {
  local what="$1" json="$2" expr="$3"
  if python3 -c "import json,sys; j=json.loads(sys.argv[1]); sys.exit(0 if ($expr) else 1)" "$json" 2>/dev/null
  then ok "$what"; else bad "$what: $expr -- $(echo "$json" | head -c 600)"; fi
}
# render_json ARGS...: the JSON line of a render (empty on failure)
render_json() { "$HZ" render --quiet --json --width 320 --height 180 --effects none "$@" 2>"$TMP/err.txt" | tail -1; }

# auto: 256 cells of 195 m are 49.9 km (flat), of 196 m 50.2 km (curved).
j=$(render_json --generate perlin --size 257 --spacing 195 --out "$TMP/a195.png")
judge "auto below 50 km is flat" "$j" 'j["curvature"] is False and j["earth_radius_m"] is None'
j=$(render_json --generate perlin --size 257 --spacing 196 --out "$TMP/a196.png")
judge "auto above 50 km is curved, mean radius" "$j" \
  'j["curvature"] is True and abs(j["earth_radius_m"] - 6371008.8) < 1 and j["earth_radius_source"] == "mean" and abs(j["curvature_edge_drop_m"] - 25088**2 / (2 * 6371008.8)) < 0.2'
j=$(render_json --generate perlin --size 257 --spacing 10 --curvature=on --out "$TMP/on.png")
judge "--curvature=on on a small map" "$j" 'j["curvature"] is True'
j=$(render_json --generate perlin --size 257 --spacing 400 --curvature off --out "$TMP/off.png")
judge "--curvature off on a large map" "$j" 'j["curvature"] is False and j["curvature_edge_drop_m"] == 0'

out=$("$HZ" render --curvature maybe --generate perlin --size 129 --out "$TMP/x.png" 2>&1 >/dev/null); rc=$?
if [ $rc -eq 2 ] && echo "$out" | grep -q "invalid value 'maybe' for --curvature: expected on, off or auto"; then ok "bad value refused"
else bad "bad value: exit $rc: $out"; fi
out=$("$HZ" render --curvture on --generate perlin --size 129 --out "$TMP/x.png" 2>&1 >/dev/null); rc=$?
if [ $rc -ne 0 ] && echo "$out" | grep -q -- "--curvature"; then ok "typo suggests --curvature"; else bad "typo: exit $rc: $out"; fi

# The Sierra mosaic (24 SRTM tiles, 125-118 W, 36-40 N): WGS84 radius at its
# centre (38 N: 6 372 955 m), the drop at half its longer side.
S="$DATA/srtm_sierra_coast"
j=$(render_json --dem "$S" --spacing 400 --camera 315000,30000,380000,0,-8 --far 800000 --out "$TMP/sierra_on.png")
judge "Sierra: curved, WGS84 radius at 38 N" "$j" \
  'j["curvature"] is True and j["earth_radius_source"] == "wgs84" and abs(j["earth_radius_m"] - 6372955) < 300'
judge "Sierra: edge drop = (half the longer side)^2 / 2R" "$j" \
  'abs(j["curvature_edge_drop_m"] - ((max(j["data_size"]) - 1) * j["spacing"] / 2) ** 2 / (2 * j["earth_radius_m"])) < 1 and 6000 < j["curvature_edge_drop_m"] < 9000'
echo "     Sierra: data $(python3 -c "import json,sys; j=json.loads(sys.argv[1]); print(j['data_size'], 'x', j['spacing'], 'm; edge drop', j['curvature_edge_drop_m'], 'm')" "$j")"
j2=$(render_json --dem "$S" --spacing 400 --camera 315000,30000,380000,0,-8 --far 800000 --curvature off --out "$TMP/sierra_off.png")
judge "Sierra: off" "$j2" 'j["curvature"] is False'
# The far terrain falls below the horizon: more sky rows with curvature.
if python3 - "$TMP/sierra_on.png" "$TMP/sierra_off.png" <<PY
import sys
sys.path.insert(0, "$HERE")
import pngstat
def sky(p):
    w, h, rows = pngstat.read(p)
    return sum(1 for r in rows for (R, G, B) in r if B > R + 30 and B >= G and B > 150)
on, off = sky(sys.argv[1]), sky(sys.argv[2])
print("     sky pixels: on %d, off %d" % (on, off))
sys.exit(0 if on > off + 320 * 3 else 1)
PY
then ok "Sierra: the far terrain sinks (more sky with curvature)"; else bad "Sierra: no more sky with curvature"; fi

# bench (in-memory): the JSON of the run.
if "$HZ" bench --quiet --generate perlin --size 257 --spacing 400 --frames 3 --width 160 --height 90 \
     --json "$TMP/bench.json" >/dev/null 2>"$TMP/bench.err"; then
  judge "bench JSON: curved (auto, 102 km)" "$(cat "$TMP/bench.json")" \
    '(j["compare"][0] if "compare" in j else j)["curvature"] is True'
else bad "bench: $(tail -c 400 "$TMP/bench.err")"; fi

# view: a few frames in a window, the JSON summary.
if [ -n "${DISPLAY:-}" ]; then
  j=$("$HZ" view --quiet --json --frames 3 --width 320 --height 180 --generate perlin --size 257 --spacing 400 \
        --curvature on 2>"$TMP/view.err" | tail -1)
  judge "view JSON: curved" "$j" 'j["curvature"] is True and abs(j["earth_radius_m"] - 6371008.8) < 1'
else
  bad "no DISPLAY for horizon view (run under scripts/with-xvfb.sh)"
fi

# The streamed path: a pyramid of one SRTM tile (79 km: auto is on).
if "$HZ" import "$DATA/N44W072.hgt" --out "$TMP/n44.hzp" >/dev/null 2>"$TMP/import.err"; then
  j=$("$HZ" render --quiet --json --terrain "$TMP/n44.hzp" --width 320 --height 180 --out "$TMP/s_on.png" 2>"$TMP/s.err" | tail -1)
  judge "streamed render: auto curved, WGS84" "$j" 'j["curvature"] is True and j["earth_radius_source"] == "wgs84"'
  j=$("$HZ" render --quiet --json --terrain "$TMP/n44.hzp" --curvature off --width 320 --height 180 --out "$TMP/s_off.png" 2>"$TMP/s.err" | tail -1)
  judge "streamed render: off" "$j" 'j["curvature"] is False'
  j=$("$HZ" bench --quiet --json --terrain "$TMP/n44.hzp" --frames 3 --width 160 --height 90 --curvature on 2>"$TMP/sb.err" | tail -1)
  judge "streamed bench: on" "$j" 'j["curvature"] is True'
  out=$("$HZ" render --terrain "$TMP/n44.hzp" --curvature sometimes --out "$TMP/x.png" 2>&1 >/dev/null); rc=$?
  if [ $rc -eq 2 ] && echo "$out" | grep -q "expected on, off or auto"; then ok "streamed: bad value refused"
  else bad "streamed bad value: exit $rc: $out"; fi
else bad "import: $(tail -c 400 "$TMP/import.err")"; fi

echo "$passes passed, $fails failed"
[ $fails -eq 0 ]
