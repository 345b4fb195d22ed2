#!/usr/bin/env bash
# horizon view --terrain NAME.hzp (issue 12): a scripted flight over a streamed
# pyramid moves the camera, loads tiles while flying, and once it holds still
# shows what `render --terrain` draws at the same camera. Bad input is refused.
# Runs under scripts/with-xvfb.sh.
set -u
HZ="$1"; TMP="$2"
mkdir -p "$TMP"
fails=0; passes=0
ok() { echo "ok   $1"; passes=$((passes + 1)); }
bad() { echo "FAIL $1"; fails=$((fails + 1)); }
"$HZ" import --generate perlin --size 2049 --seed 3 --out "$TMP/p.hzp" --quiet || { echo "FAIL import"; exit 1; }
# W held 40 frames (1/30 s each), then still for 60 frames (tiles load and slide in)
printf '0 key W down\n40 key W up\n' > "$TMP/fly.txt"
out=$("$HZ" view --terrain "$TMP/p.hzp" --camera 3000,1600,3000,135,-12 --speed 300 --frames 100 \
      --script "$TMP/fly.txt" --no-hud --width 480 --height 270 --screenshot "$TMP/view.png" --json --quiet 2>"$TMP/err.txt")
rc=$?
cat "$TMP/err.txt"
echo "$out"
if [ $rc -eq 0 ] && [ -s "$TMP/view.png" ]; then ok "view --terrain flies a script and writes the screenshot"; else bad "view --terrain (exit $rc)"; fi
read -r x y z yaw pitch loaded < <(python3 -c '
import json,sys
j=json.loads(sys.argv[1]); c=j["camera"]
print(c[0],c[1],c[2],c[3],c[4],j["tiles_loaded"])' "$out" 2>/dev/null) || { bad "view --json"; x=0; }
# 40 frames at 300 m/s toward yaw 135 (south-east): about 400 m along +x and +z
if python3 -c "import sys; x,z=float('$x'),float('$z'); sys.exit(0 if 3200<x<3400 and 3200<z<3400 else 1)"; then
  ok "the camera flew south-east ($x, $z)"
else
  bad "the camera did not fly as scripted ($x, $z)"
fi
if [ "${loaded:-0}" -gt 0 ]; then ok "tiles streamed in while flying ($loaded)"; else bad "no tile loaded"; fi
# the still view equals a streamed render at the same camera
"$HZ" render --terrain "$TMP/p.hzp" --camera "$x,$y,$z,$yaw,$pitch" --width 480 --height 270 --out "$TMP/render.png" --quiet
diff=$(python3 - "$TMP/view.png" "$TMP/render.png" <<'PY'
import sys, os
sys.path.insert(0, os.path.join(os.environ.get("SRC", "."), "tests", "cli"))
import pngstat
w1, h1, a = pngstat.read(sys.argv[1]); w2, h2, b = pngstat.read(sys.argv[2])
assert (w1, h1) == (w2, h2)
s = sum(abs(p[k] - q[k]) for ra, rb in zip(a, b) for p, q in zip(ra, rb) for k in range(3))
print("%.3f" % (s / (3.0 * w1 * h1)))
PY
)
if python3 -c "import sys; sys.exit(0 if float('${diff:-999}') < 2.0 else 1)"; then
  ok "the still view matches render --terrain (mean difference $diff of 255)"
else
  bad "the view differs from render --terrain (mean difference ${diff:-?})"
fi
# bad input
"$HZ" view --terrain "$TMP/missing.hzp" --frames 2 2>"$TMP/e1.txt"; rc=$?
if [ $rc -ne 0 ] && grep -q "missing.hzp" "$TMP/e1.txt"; then ok "a missing pyramid is refused"; else bad "missing pyramid (exit $rc)"; fi
"$HZ" view --terrain "$TMP/p.hzp" --screenshot "$TMP/p.hzp" --frames 2 2>"$TMP/e2.txt"; rc=$?
if [ $rc -eq 2 ] && cmp -s "$TMP/p.hzp" "$TMP/p.hzp" && grep -q "refusing" "$TMP/e2.txt"; then ok "a screenshot onto the pyramid is refused"; else bad "screenshot onto the input (exit $rc)"; fi
"$HZ" render --terrain "$TMP/p.hzp" --script "$TMP/fly.txt" 2>"$TMP/e3.txt"; rc=$?
if [ $rc -eq 2 ] && grep -q "option of horizon view" "$TMP/e3.txt"; then ok "render refuses a view option"; else bad "render --script (exit $rc)"; fi
echo "$passes passed, $fails failed"
exit $((fails > 0))
