#!/usr/bin/env bash
# horizon view as a user runs it, in a real window on Xvfb (run by ctest under
# xvfb-run): scripted flights over a generated terrain and a real DEM exit 0
# and their final screenshots show terrain, sky and the HUD; a mid-run resize
# keeps rendering at the new size; the debug views render what they promise;
# keys, scripts and config files do what the README says; bad input gives a
# message and a non-zero exit status, never a crash.
set -u
HZ="$1"; PNG="$2"; DATA="$3"; TMP="$4"
mkdir -p "$TMP"
fails=0; passes=0
ok()  { passes=$((passes+1)); echo "ok   $*"; }
bad() { fails=$((fails+1)); echo "FAIL $*"; }

if [ -z "${DISPLAY:-}" ]; then
  echo "FAIL no DISPLAY: run under xvfb-run (scripts/deps.sh installs xvfb)"; exit 1
fi

# judge "what" JSON 'python expression over j'
judge() {
  local what="$1" json="$2" expr="$3"
  if python3 -c "import json,sys; j=json.loads(sys.argv[1]); sys.exit(0 if ($expr) else 1)" "$json" 2>/dev/null
  then ok "$what"; else bad "$what: $expr -- $json"; fi
}

# run NAME args...: runs the viewer with --json, keeps stdout in $OUT, stderr in $TMP/NAME.err, exit in $RC
run() {
  local name="$1"; shift
  OUT=$("$HZ" view --quiet --json "$@" 2>"$TMP/$name.err"); RC=$?
  if [ $RC -ne 0 ]; then bad "$name: exit $RC: $(tail -c 600 "$TMP/$name.err")"; OUT='{}'; return 1; fi
  return 0
}

# expect_fail "what" "message regex" args...
expect_fail() {
  local what="$1" re="$2"; shift 2
  local out rc
  out=$("$HZ" view --quiet "$@" 2>&1 >/dev/null); rc=$?
  if [ $rc -ne 0 ] && [ $rc -lt 128 ] && echo "$out" | grep -Eqi -- "$re"; then ok "$what (exit $rc)"
  else bad "$what: exit $rc, stderr: $out"; fi
}

shot() { "$PNG" "$1" 2>&1 || echo '{}'; }

GEN=(--generate perlin --size 1025 --seed 3)

# 1. A scripted 60-frame flight over a generated terrain: forward, turning,
#    a burst of speed, a look up and down. Final screenshot: terrain + sky + HUD.
cat > "$TMP/flight.txt" <<'EOF'
# frame  event
0   key W down
10  key SHIFT down
20  key SHIFT up
20  look 25 -5
30  button left down
30  mouse 80 -20
31  button left up
40  key RIGHT down
50  key RIGHT up
59  key W up
EOF
# The start camera (the default: it frames the highest ground), from render.
START=$("$HZ" render --quiet --width 1280 --height 720 "${GEN[@]}" --effects none --json --out "$TMP/start.png" |
        python3 -c "import json,sys; print(json.dumps(json.load(sys.stdin)['camera']))")
if run flight_gen "${GEN[@]}" --frames 60 --script "$TMP/flight.txt" --screenshot "$TMP/flight_gen.png"; then
  judge "generated flight: 60 frames, 1280x720" "$OUT" 'j["frames"]==60 and j["width"]==1280 and j["height"]==720 and j["screenshots"]==1'
  judge "generated flight: terrain drawn" "$OUT" 'j["triangles"]>1000 and j["fps_mean"]>0'
  judge "view: the default LOD is cdlod at 1 px" "$OUT" 'j["lod_mode"]=="cdlod" and j["pixel_error"]==1'
  # Issue 15: the compact HUD leaves the view (one corner: under 30 % of the width, 20 % of the height).
  judge "view: compact HUD by default, in one corner" "$OUT" \
    'j["hud"]=="compact" and 0 < j["hud_size"][0] < 0.3*1280 and 0 < j["hud_size"][1] < 0.2*720'
  judge "generated flight: the camera moved and turned" "$OUT" \
    "abs(j['camera'][0]-$START[0])+abs(j['camera'][2]-$START[2])>100 and abs(j['camera'][3]-$START[3])>20"
  s=$(shot "$TMP/flight_gen.png")
  judge "generated flight screenshot: terrain, sky and HUD text" "$s" \
    'j["width"]==1280 and j["height"]==720 and j["sky"]>0.05 and j["terrain"]>0.2 and j["hud_text"]>0.01'
fi

# 2. The same on a real DEM (SRTM .hgt, reprojected to UTM 19N: 1252x1714 in a 2049 grid).
if run flight_dem --dem "$DATA/N44W072.hgt" --frames 60 --script "$TMP/flight.txt" --screenshot "$TMP/flight_dem.png"; then
  judge "DEM flight: 60 frames" "$OUT" 'j["frames"]==60 and j["triangles"]>1000 and j["heightmap_size"]==2049'
  s=$(shot "$TMP/flight_dem.png")
  judge "DEM flight screenshot: terrain, sky and HUD text" "$s" \
    'j["width"]==1280 and j["height"]==720 and j["sky"]>0.05 and j["terrain"]>0.2 and j["hud_text"]>0.01'
fi

# 3. Resizing the window mid-run keeps rendering, at the new size.
cat > "$TMP/resize.txt" <<'EOF'
0  key W down
10 screenshot RESIZE_BEFORE
20 resize 800 500
40 screenshot RESIZE_MID
45 resize 1024 640
59 key W up
EOF
sed -i "s|RESIZE_BEFORE|$TMP/resize_before.png|; s|RESIZE_MID|$TMP/resize_mid.png|" "$TMP/resize.txt"
if run resize "${GEN[@]}" --frames 60 --script "$TMP/resize.txt" --screenshot "$TMP/resize_end.png"; then
  judge "resize: 60 frames, final size 1024x640" "$OUT" 'j["frames"]==60 and j["width"]==1024 and j["height"]==640'
  judge "resize: before, 1280x720" "$(shot "$TMP/resize_before.png")" 'j["width"]==1280 and j["height"]==720 and j["sky"]>0.05 and j["terrain"]>0.2'
  judge "resize: after the first resize, 800x500 with terrain and sky" "$(shot "$TMP/resize_mid.png")" \
    'j["width"]==800 and j["height"]==500 and j["sky"]>0.05 and j["terrain"]>0.2'
  judge "resize: last frame 1024x640 with terrain and sky" "$(shot "$TMP/resize_end.png")" \
    'j["width"]==1024 and j["height"]==640 and j["sky"]>0.05 and j["terrain"]>0.2'
fi

# 3b. F6: the full HUD (every figure), F6 again the compact corner.
printf '0 key F6 press\n' > "$TMP/hudfull.txt"
if run hudfull "${GEN[@]}" --size 257 --frames 2 --script "$TMP/hudfull.txt"; then
  judge "F6: the full HUD is wider and taller than the compact one" "$OUT" \
    'j["hud"]=="full" and j["hud_size"][0] > 0.45*1280 and j["hud_size"][1] > 0.2*720'
fi
printf '0 key F6 press\n1 key F6 press\n' > "$TMP/hudback.txt"
if run hudback "${GEN[@]}" --size 257 --frames 3 --script "$TMP/hudback.txt"; then
  judge "F6 twice: back to the compact HUD" "$OUT" 'j["hud"]=="compact" and j["hud_size"][0] < 0.3*1280'
fi

# 4. The seed's fan view: centre red, rim white, finest-level fans blue.
cat > "$TMP/fans.txt" <<'EOF'
0 key F3 press
0 key F1 press
EOF
if run fans "${GEN[@]}" --frames 3 --script "$TMP/fans.txt" --screenshot "$TMP/fans.png"; then
  judge "fan view on" "$OUT" 'j["fans"] is True'
  judge "fan view screenshot: red centres, white rims, blue finest fans, sky" "$(shot "$TMP/fans.png")" \
    'j["red"]>0.005 and j["white"]>0.01 and j["blue"]>0.02 and j["sky"]>0.05'
fi

# 5. Every debug view and key renders: wireframe, freeze + fly away (frustum,
#    culled boxes), node boxes, help, culling off/on, C/C2 keys, Tab, walk.
cat > "$TMP/debug.txt" <<'EOF'
0  key F2 press
2  key F4 press
3  key F5 press
4  key H press
5  key 2 press
7  key 2 press
9  key 3 press
11 key K press
13 key K press
14 key TAB press
15 key S down
15 key E down
25 key S up
25 key E up
26 screenshot DEBUG_SHOT
27 key F2 press
EOF
sed -i "s|DEBUG_SHOT|$TMP/debug_frozen.png|" "$TMP/debug.txt"
if run debug "${GEN[@]}" --frames 30 --script "$TMP/debug.txt"; then
  judge "debug keys: frozen, boxes, wire off again, free camera" "$OUT" \
    'j["frozen"] and j["boxes"] and not j["wireframe"] and j["camera_mode"]=="free" and not j["no_cull"]'
  judge "debug keys: C x1.25 twice, C2 / 1.25" "$OUT" 'abs(j["lod_c"]-39.0625)<0.01 and abs(j["lod_c2"]-2.0)<0.001'
  judge "debug keys: the frozen frame was saved" "$OUT" 'j["screenshots"]==1'
  s=$(shot "$TMP/debug_frozen.png")
  judge "frozen LOD camera screenshot: sky and something drawn" "$s" 'j["sky"]>0.05 and j["red"]+j["terrain"]>0.01'
fi

# 6. Movement semantics end to end: yaw 90 + W moves toward +x by speed * time.
cat > "$TMP/east.txt" <<'EOF'
0  camera 3000 2500 3000 90 0
1  key W down
31 key W up
EOF
if run east "${GEN[@]}" --frames 33 --script "$TMP/east.txt" --speed 100 --width 640 --height 360; then
  judge "yaw 90 + W for 1 s at 100 m/s: x +100, y and z unchanged" "$OUT" \
    'abs(j["camera"][0]-3100)<0.5 and abs(j["camera"][1]-2500)<0.5 and abs(j["camera"][2]-3000)<0.5'
fi

# 7. Walk mode keeps the eye at ground + eye height while walking uphill and down.
cat > "$TMP/walk.txt" <<'EOF'
0  key W down
0  key SHIFT down
59 key W up
EOF
if run walk "${GEN[@]}" --walk --eye-height 2 --frames 60 --script "$TMP/walk.txt" --width 640 --height 360 \
     --screenshot "$TMP/walk.png"; then
  judge "walk mode: eye 2 m above the ground" "$OUT" 'j["camera_mode"]=="walk" and abs(j["camera"][1]-j["ground"]-2)<0.01'
  judge "walk mode: moved (walk speed x fast)" "$OUT" 'abs(j["camera"][0]-5120)+abs(j["camera"][2]-5120)>50'
fi

# 8. Config file, command line wins; a camera path; Esc quits early.
cat > "$TMP/view.conf" <<'EOF'
# horizon view settings
generate = perlin
size = 513
seed = 5
lod-c = 40      # distance factor
lod-c2 = "3"
wireframe = true
frames = 4
width = 640
height = 360
EOF
if run config --config "$TMP/view.conf"; then
  judge "config: values used" "$OUT" 'j["lod_c"]==40 and j["lod_c2"]==3 and j["wireframe"] and j["frames"]==4 and j["heightmap_size"]==513'
fi
if run config_override --config "$TMP/view.conf" --lod-c 30 --frames 2 --size 257; then
  judge "config: the command line wins" "$OUT" 'j["lod_c"]==30 and j["frames"]==2 and j["heightmap_size"]==257 and j["lod_c2"]==3'
fi
if run path "${GEN[@]}" --path orbit --frames 20 --width 640 --height 360 --screenshot "$TMP/path.png"; then
  judge "camera path: 20 frames" "$OUT" 'j["frames"]==20'
  judge "camera path screenshot: terrain and sky" "$(shot "$TMP/path.png")" 'j["sky"]>0.02 and j["terrain"]>0.2'
fi
printf '5 key ESC press\n' > "$TMP/esc.txt"
if run esc "${GEN[@]}" --frames 100 --script "$TMP/esc.txt" --width 640 --height 360 --screenshot "$TMP/esc.png"; then
  judge "Esc quits after the frame it was pressed in" "$OUT" 'j["frames"]==6 and j["screenshots"]==1'
fi

# 8b. LOD modes in the window: start in cdlod (geomorphing on the GPU), fly,
#     L cycles to quadtree (wraps around), 6 raises the pixel error.
cat > "$TMP/modes.txt" <<'EOF'
0  key W down
10 screenshot MODES_CDLOD
12 key L press
14 key 6 press
20 key W up
EOF
sed -i "s|MODES_CDLOD|$TMP/modes_cdlod.png|" "$TMP/modes.txt"
if run modes "${GEN[@]}" --lod cdlod --pixel-error 2 --frames 22 --script "$TMP/modes.txt" --width 640 --height 360 \
     --screenshot "$TMP/modes_end.png"; then
  judge "L key: cdlod -> quadtree, 6: pixel error x1.25" "$OUT" \
    'j["lod_mode"]=="quadtree" and abs(j["pixel_error"]-2.5)<1e-4 and j["triangles"]>1000'
  judge "cdlod frame in the window: terrain and sky" "$(shot "$TMP/modes_cdlod.png")" 'j["sky"]>0.02 and j["terrain"]>0.2'
fi

# 9. Effect keys: weather on and to snow, bloom off, the sun 15 degrees east and 5 up
#    (the light map follows); --effects none starts with nothing.
cat > "$TMP/fx.txt" <<'EOF'
0 key N press
1 key C press
2 key Z press
3 key ] press
4 key = press
EOF
SMALL=(--generate perlin --size 257 --seed 3 --width 640 --height 360)
if run fxkeys "${SMALL[@]}" --frames 6 --script "$TMP/fx.txt" --sun 100,20 --screenshot "$TMP/fxkeys.png"; then
  judge "effect keys: weather on (snow), bloom off" "$OUT" \
    'j["effects"]=="sky,flare,shadows,detail,billboards,fog,water,weather" and j["weather"]=="snow" and j["particles"]>0'
  judge "effect keys: sun moved to azimuth 115, elevation 25" "$OUT" 'abs(j["sun"][0]-115)<0.5 and abs(j["sun"][1]-25)<0.5'
  judge "effect keys screenshot: terrain, sky and HUD" "$(shot "$TMP/fxkeys.png")" 'j["sky"]>0.02 and j["terrain"]>0.1 and j["hud_text"]>0.01'
fi
if run fxnone "${SMALL[@]}" --frames 2 --effects none; then
  judge "--effects none" "$OUT" 'j["effects"]=="none" and j["particles"]==0 and j["billboards"]==0'
fi
expect_fail "bad --effects"          "unknown effect"             "${SMALL[@]}" --effects sky,smoke --frames 2

# 10. Bad input: a message on the terminal and exit != 0, never a crash.
expect_fail "missing DEM"            "cannot open|no such"        --dem "$TMP/nope.hgt" --frames 5
head -c 100000 "$DATA/N44W072.hgt" > "$TMP/trunc.hgt"
expect_fail "truncated DEM"          "trunc|bytes|square"         --dem "$TMP/trunc.hgt" --frames 5
head -c 5000 /dev/urandom > "$TMP/garbage.png"
expect_fail "garbage PNG DEM"        "png|format|garbage|corrupt" --dem "$TMP/garbage.png" --frames 5
python3 -c "import struct,sys; sys.stdout.buffer.write(struct.pack('<25f', *([1.0]*12+[float('inf')]+[1.0]*12)))" > "$TMP/inf.r32"
expect_fail "inf in a raw DEM"       "inf|finite"                 --dem "$TMP/inf.r32" --frames 5
printf '0 key W down\n3 jump\n' > "$TMP/bad_script.txt"
expect_fail "bad script line"        "bad_script.txt:2"           "${GEN[@]}" --script "$TMP/bad_script.txt"
printf '0 key NOPE down\n' > "$TMP/bad_key.txt"
expect_fail "unknown key in script"  "unknown key"                "${GEN[@]}" --script "$TMP/bad_key.txt"
expect_fail "missing script"         "cannot open script"         "${GEN[@]}" --script "$TMP/none.txt"
expect_fail "missing --shot-dir"      "shot-dir.*no such file"     "${GEN[@]}" --shot-dir "$TMP/no_such_dir" --frames 5
expect_fail "missing config"         "cannot open config"         --config "$TMP/none.conf"
printf 'lod-c 40\n' > "$TMP/bad.conf"
expect_fail "config without ="       "bad.conf:1"                 --config "$TMP/bad.conf"
printf 'frobnicate = 3\n' > "$TMP/unknown.conf"
expect_fail "unknown config key"     "unknown option"             --config "$TMP/unknown.conf"
expect_fail "bad --frames"           "invalid value"              --frames 0
expect_fail "unknown path"           "unknown path|path"          "${GEN[@]}" --size 257 --path nowhere --frames 2
expect_fail "render-only option"     "belong to render"           --out x.png
expect_fail "unknown LOD mode"       "invalid value.*--lod"       --lod nope
out=$(env -u DISPLAY "$HZ" view --quiet "${GEN[@]}" --frames 2 2>&1 >/dev/null); rc=$?
if [ $rc -ne 0 ] && [ $rc -lt 128 ] && echo "$out" | grep -Eqi "display|xvfb"; then ok "no X display (exit $rc)"
else bad "no X display: exit $rc, stderr: $out"; fi

# A forest in the window: small generated trees (cached in TMP), flown along the forest path.
if run forest "${GEN[@]}" --size 513 --forest 60 --forest-leaves 600 --tree-cache "$TMP/trees" --path forest \
       --frames 8 --width 480 --height 300 --screenshot "$TMP/forest.png"; then
  judge "forest: trees selected and drawn" "$OUT" 'j["forest_trees"] == 60 and j["forest_triangles_drawn"] > 1000 and j["frames"] == 8'
  [ -s "$TMP/forest.png" ] && ok "forest screenshot" || bad "forest screenshot missing"
fi
expect_fail "forest path without --forest" "needs --forest"     "${GEN[@]}" --size 257 --path forest --frames 2

echo "test_view: $passes passed, $fails failed"
[ $fails -eq 0 ]
