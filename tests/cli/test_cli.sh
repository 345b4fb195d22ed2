#!/usr/bin/env bash
# The horizon command as a user runs it: good runs produce images, JSON and OBJ
# with the promised properties; bad input gives a clear message and exit != 0.
set -u
HZ="$1"; DATA="$2"; TMP="$3"
mkdir -p "$TMP"
fails=0; passes=0
ok()   { passes=$((passes+1)); echo "ok   $*"; }
bad()  { fails=$((fails+1)); echo "FAIL $*"; }

# expect_fail "what" "message regex" cmd...
expect_fail() {
  local what="$1" re="$2"; shift 2
  local out rc
  out=$("$@" 2>&1 >/dev/null); rc=$?
  if [ $rc -ne 0 ] && [ $rc -lt 128 ] && echo "$out" | grep -Eqi -- "$re"; then ok "$what (exit $rc)"
  else bad "$what: exit $rc, stderr: $out"; fi
}

R="$HZ render --quiet --width 320 --height 180"
expect_fail "no command"            "usage"                   $HZ
expect_fail "unknown command"       "unknown command"         $HZ frobnicate
expect_fail "unknown option"        "unknown option"          $R --frob
expect_fail "missing DEM"           "cannot open|no such"     $R --dem "$TMP/nope.hgt"
expect_fail "size not 2^n+1"        "2\^n\+1"                 $R --generate perlin --size 1000
expect_fail "NaN C"                 "invalid value"           $R --lod-c nan
expect_fail "negative spacing"      "invalid value"           $R --spacing -3
expect_fail "short camera"          "X,Y,Z,YAW,PITCH"         $R --camera 1,2,3
expect_fail "zero width"            "invalid value"           $R --width 0
expect_fail "dem and generate"      "either"                  $R --dem x.hgt --generate perlin
head -c 100000 "$DATA/N44W072.hgt" > "$TMP/trunc.hgt"
expect_fail "truncated hgt"         "trunc|bytes|square"      $R --dem "$TMP/trunc.hgt"
head -c 5000 /dev/urandom > "$TMP/garbage.png"
expect_fail "garbage png"           "png|format|garbage|corrupt" $R --dem "$TMP/garbage.png"
printf 'not gzip at all' > "$TMP/bad.hgt.gz"
expect_fail "bad gzip"              "gzip|trunc|corrupt|format" $R --dem "$TMP/bad.hgt.gz"
python3 -c "import struct,sys; sys.stdout.buffer.write(struct.pack('<25f', *([1.0]*12+[float('inf')]+[1.0]*12)))" > "$TMP/inf.r32"
expect_fail "inf in r32"            "inf|finite"              $R --dem "$TMP/inf.r32"
expect_fail "unknown extension"     "format|extension"        $R --dem "$DATA/PROVENANCE.md"

# A good run: JSON has every figure, OBJ matches it, the image exists.
json=$($R --generate perlin --size 513 --seed 3 --json --out "$TMP/a.png" --dump-mesh "$TMP/a.obj")
rc=$?
if [ $rc -eq 0 ] && python3 - "$json" "$TMP/a.obj" <<'PY'
import json, sys
j = json.loads(sys.argv[1])
need = ["triangles","vertices","nodes_visited","nodes_culled","lod_ms","draw_ms","heightmap_size","bytes_per_sample"]
missing = [k for k in need if k not in j]
assert not missing, missing
assert j["heightmap_size"] == 513 and j["triangles"] > 100 and 0 < j["bytes_per_sample"] < 8, j
v = f = 0
for line in open(sys.argv[2]):
    if line.startswith("v "): v += 1
    elif line.startswith("f "):
        f += 1
        ids = [int(x) for x in line.split()[1:]]
        assert len(ids) == 3 and all(1 <= i for i in ids)
assert f == j["triangles"] and v == j["vertices"], (f, v, j["triangles"], j["vertices"])
PY
then ok "render --json/--dump-mesh agree"; else bad "render --json/--dump-mesh (exit $rc): $json"; fi
[ -s "$TMP/a.png" ] && ok "image written" || bad "no image"

# Same seed -> same image; other seed -> other image.
$R --generate perlin --size 513 --seed 3 --out "$TMP/b.png" >/dev/null 2>&1
$R --generate perlin --size 513 --seed 4 --out "$TMP/c.png" >/dev/null 2>&1
cmp -s "$TMP/a.png" "$TMP/b.png" && ok "repeatable render" || bad "same seed gave a different image"
cmp -s "$TMP/a.png" "$TMP/c.png" && bad "different seeds gave the same image" || ok "seed changes terrain"

# More C*C2 -> more triangles.
t1=$($R --generate diamond --size 1025 --lod-c 25 --lod-c2 2.5 --json --out "$TMP/d.png" | python3 -c "import json,sys;print(json.load(sys.stdin)['triangles'])")
t2=$($R --generate diamond --size 1025 --lod-c 50 --lod-c2 5 --json --out "$TMP/d.png" | python3 -c "import json,sys;print(json.load(sys.stdin)['triangles'])")
[ -n "$t1" ] && [ -n "$t2" ] && [ "$t2" -gt "$t1" ] && ok "C*C2 raises triangles ($t1 -> $t2)" || bad "triangles $t1 -> $t2"

# A real DEM that is not 2^n+1: fitted with a note, rendered.
err=$($HZ render --width 320 --height 180 --dem "$DATA/sthelens_10m_dm16.png" --out "$TMP/sh.png" 2>&1 >/dev/null)
rc=$?
[ $rc -eq 0 ] && echo "$err" | grep -Eqi "pad|crop" && ok "non-2^n+1 DEM fitted: $(echo "$err" | grep -Ei 'pad|crop' | head -1)" || bad "sthelens (exit $rc): $err"

echo "$passes passed, $fails failed"
[ $fails -eq 0 ]
