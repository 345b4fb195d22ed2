#!/usr/bin/env bash
# The standard benchmark set: writes out/bench/*.json and out/bench/summary.md.
#   bench/standard.sh [HORIZON_BINARY] [DATA_DIR]
# FRAMES=N overrides the frame count of every run (quick look: FRAMES=5).
set -euo pipefail
HZ=${1:-build/apps/horizon/horizon}
DATA=${2:-../shared/data}
OUT=out/bench
mkdir -p "$OUT"
F=${FRAMES:-}

run() { # name, frames, args...
  local name=$1 frames=$2; shift 2
  [ -n "$F" ] && frames=$F
  echo "== $name ($frames frames)" >&2
  "$HZ" bench --quiet --frames "$frames" --json "$OUT/$name.json" "$@" >/dev/null
}
# The LOD runs below measure the terrain alone (--effects none, so their
# figures stay comparable from run to run); the effects have their own runs
# at the end.
lod() { # name, frames, args...
  local name=$1 frames=$2; shift 2
  run "$name" "$frames" --effects none "$@"
}

# The seed's table (SPEC T9): 2049^2 map, view distance 600 samples (6 km at 10 m),
# C=25/C2=2.5 and C=50/C2=5, with the seed's unclamped criterion and Roettger's clamped one.
for crit in unclamped clamped; do
  lod "seed_c25_${crit}" 60 --generate perlin --size 2049 --seed 1 --far 6000 --lod quadtree --lod-c 25 --lod-c2 2.5 --criterion $crit --path flyover
  lod "seed_c50_${crit}" 60 --generate perlin --size 2049 --seed 1 --far 6000 --lod quadtree --lod-c 50 --lod-c2 5 --criterion $crit --path flyover
done

# Scale: the same flight over growing generated maps (reference off: speed and memory), with
# the default LOD (cdlod, 1 px), as are the real DEMs below.
for s in 1025 2049 4097 8193; do
  lod "scale_$s" 30 --generate perlin --size $s --seed 1 --path flyover --reference off
done

# Real DEMs (fitted to 2^n+1 as horizon render does).
lod dem_N44W072      60 --dem "$DATA/N44W072.hgt" --path flyover
lod dem_S46W066      30 --dem "$DATA/S46W066.hgt.gz" --path flyover
lod dem_sierra       30 --dem "$DATA/sierra_nevada_N36-N40_W122-W118_srtm3_4801x4801_int16be.raw.gz" --path flyover
lod dem_sthelens     60 --dem "$DATA/sthelens_10m_dm16.png" --path flyover
lod dem_pyrenees     60 --dem "$DATA/pyrenees_1as_ft16.png" --path flyover
lod dem_sthelens_ground 60 --dem "$DATA/sthelens_10m_dm16.png" --path ground
lod dem_everest_orbit   60 --dem "$DATA/himalaya-everest_3as_ft16.png" --path orbit

# Effects (issue 7): the frame-time cost of each effect at 1280x720 along the
# flyover of the 4097^2 map (each alone over the bare terrain, and each taken
# out of all of them), the light map build at 4097^2 (1 and 2 threads), and
# the full default frame along the same flight.
EF=${F:-12}
echo "== effects ($EF frames x 22 configurations)" >&2
"$HZ" bench --quiet --generate perlin --size 4097 --seed 1 --path flyover --frames "$EF" --width 1280 --height 720 \
  --effect-costs "$OUT/effects.json" >/dev/null
run effects_default_flyover 30 --generate perlin --size 4097 --seed 1 --path flyover --reference off --effects default

# LOD modes compared (quadtree, remedy, bidirectional, roam, cdlod): each tuned
# to a 99th-percentile screen-space error of 1 px and of 4 px, on the same
# paths and reference frames (the 4097^2 runs take ~8 min each on 2 cores).
# COMPARE=0 skips this part.
if [ "${COMPARE:-1}" != 0 ]; then
  MODES=quadtree,remedy,bidirectional,roam,cdlod
  cmp() { # name, frames, args...
    local name=$1 frames=$2; shift 2
    [ -n "$F" ] && frames=$F
    echo "== compare $name ($frames frames)" >&2
    "$HZ" bench --quiet --frames "$frames" --lod $MODES --json "$OUT/cmp_$name.json" --effects none "$@" >/dev/null
  }
  # flyover: 30 frames at 30 fps (1 s, 300 m); ground: 30 frames at 2 fps
  # (15 s, 75 m: a walk changes the LOD slowly).
  for p in flyover ground; do
    fps=30; [ $p = ground ] && fps=2
    for px in 1 4; do
      cmp "perlin4097_${p}_${px}px" 30 --generate perlin --size 4097 --seed 1 --path $p --fps $fps --tune-p99 $px
      cmp "N44W072_${p}_${px}px"    30 --dem "$DATA/N44W072.hgt" --path $p --fps $fps --tune-p99 $px
    done
    cmp "sierra_${p}_1px" 30 --dem "$DATA/sierra_nevada_N36-N40_W122-W118_srtm3_4801x4801_int16be.raw.gz" \
                             --path $p --fps $fps --tune-p99 1
  done
fi

# The peers' test (../shared/peers: Ogre 1.12 Terrain, Irrlicht 1.8): their 4097^2 and 1025^2
# fractal maps at 10 m and their 120-frame flight (each CSV row one frame at 30 fps), made by
# their own generator (python3 stdlib), with their clip planes (near 5 m, far 1.5 x the 3-D
# diagonal). cdlod at several bounds and tuned to Ogre's image error; speed runs without the
# reference and the pixel-error pass. Put next to ../shared/peers/RESULTS.md.
PEERS=${PEERS:-$DATA/../peers}
PT=$OUT/peers_testdata
if [ -f "$PEERS/tools/gen_testdata.py" ]; then
  mkdir -p "$PT"
  if [ ! -f "$PT/fractal4097.png" ]; then
    tmp=$(mktemp -d); cp -r "$PEERS/tools" "$tmp/"; mkdir -p "$tmp/testdata"
    (cd "$tmp" && python3 tools/gen_testdata.py >&2) && cp "$tmp"/testdata/* "$PT/"
    rm -rf "$tmp"
  fi
  for m in 4097 1025; do
    # the same 40.96 km terrain: 4097^2 at 10 m, every 4th sample (1025^2) at 40 m; the peers'
    # automatic far plane (1.5 x the 3-D diagonal) is 86939.3 m for both
    sp=10; [ $m = 1025 ] && sp=40
    P="--dem $PT/fractal$m.png --spacing $sp --zscale 0.03 --path $PT/flight120.csv --fps 30 --near 5 --far 86939.3"
    for tau in 1 1.5 2; do
      lod "peers${m}_cdlod_tau$tau" 120 $P --lod cdlod --pixel-error $tau
      lod "peers${m}_cdlod_tau${tau}_speed" 120 $P --lod cdlod --pixel-error $tau --reference off --metrics off
    done
    if [ $m = 4097 ]; then
      # the narrowest morph zone: Ogre tau 1's image error at tau 1.5 (README, against Ogre)
      lod "peers4097_cdlod_tau1.5_morph0.98" 120 $P --lod cdlod --pixel-error 1.5 --morph-start 0.98
      lod "peers4097_cdlod_tau1.5_morph0.98_speed" 120 $P --lod cdlod --pixel-error 1.5 --morph-start 0.98 \
        --reference off --metrics off
      # Irrlicht's silhouette error with a near bound (README, against Irrlicht): 2 px on the
      # far ground, 8 px within 850 m; per pixel and lit per vertex as Irrlicht lights
      N="--lod cdlod --pixel-error 2 --near-pixel-error 8 --near-error-distance 850"
      lod "peers4097_cdlod_tau2_near8" 120 $P $N
      lod "peers4097_cdlod_tau2_near8_speed" 120 $P $N --reference off --metrics off
      lod "peers4097_cdlod_tau2_near8_vertex_speed" 120 $P $N --lit-map vertex --reference off --metrics off
    fi
    # at Ogre tau 1's image error (../shared/peers/RESULTS.md): median silhouette and PSNR
    if [ $m = 4097 ]; then ogre="--tune-silhouette 0.000168 --tune-psnr 41.0"; else ogre="--tune-silhouette 0.00009 --tune-psnr 46.7"; fi
    lod "peers${m}_cdlod_ogre1_image" 120 $P --lod cdlod $ogre
  done
fi

# Forests (SPEC F7): 1 660 trees of the four species (grown, VMI-ranked and cached on first use)
# on the 4097^2 map, flown 25 m above the ground across the forest; simplified frames with and
# without hysteresis, every 6th frame also unsimplified; precision/recall per species.
fr=${F:-36}
echo "== forest ($fr frames)" >&2
"$HZ" bench --quiet --generate perlin --size 4097 --seed 1 --forest 1660 --frames "$fr" --json "$OUT/forest.json" >/dev/null

# Pyramids over HTTP (issue 17): nginx on loopback and a proxy adding 50 ms per
# request; tiles/s, MB/s, the flyover paced and unpaced, frames identical -> out/bench/http.json
# and http.md. HTTP=0 skips it.
[ "${HTTP:-1}" = 0 ] || python3 bench/http_bench.py "$HZ" "$OUT"
# City models and scene objects (issue 13): bench/city.sh writes city_*.json and city.md.
bash bench/city.sh "$HZ" "$DATA" "$OUT" >/dev/null

python3 bench/summary.py "$OUT" > "$OUT/summary.md"
cat "$OUT/city.md" >> "$OUT/summary.md"
[ ! -f "$OUT/http.md" ] || cat "$OUT/http.md" >> "$OUT/summary.md"
# Terrain pyramids: import and streaming figures (PYRAMID=0 skips them, BIG=1 adds 65537^2).
if [ "${PYRAMID:-1}" = 1 ]; then
  bash bench/pyramid.sh "$HZ" "$DATA" "$PT" >/dev/null
  cat "$OUT/pyramid.md" >> "$OUT/summary.md"
fi
# Every DEM in the data folder through --dem: what is shown of it.
python3 bench/dems.py "$HZ" "$DATA" "$OUT/dems" >> "$OUT/summary.md"
cat "$OUT/summary.md"
