#!/usr/bin/env bash
# Terrain pyramids (issue figures): imports and streamed flights, then
# out/bench/pyramid.md. Called by bench/standard.sh; alone:
#   bench/pyramid.sh [HORIZON_BINARY] [DATA_DIR] [PEERS_TESTDATA_DIR]
# BIG=1 also imports and flies a 65537^2 generated terrain (~1 h, ~3 GB disk).
set -euo pipefail
HZ=${1:-build/apps/horizon/horizon}
DATA=${2:-../shared/data}
PT=${3:-out/bench/peers_testdata}
OUT=out/bench
P=$OUT/pyramids
mkdir -p "$P"
tv() { /usr/bin/time -f '%M' -o "$1.rss" "${@:2}"; }   # peak RSS (kB) of a run into NAME.rss

# 16385^2 generated (268 M samples): import, then the flyover with a 512 MB cache.
echo "== pyramid: import 16385^2 perlin" >&2
tv "$P/g16k_import" "$HZ" import --generate perlin --size 16385 --seed 1 --out "$P/g16k.hzp" --quiet --json > "$P/g16k_import.json"
echo "== pyramid: flyover 16385^2 streamed, 512 MB cache" >&2
tv "$P/g16k_fly" "$HZ" bench --terrain "$P/g16k.hzp" --path flyover --cache-mb 512 --frames 120 --json > "$P/g16k_fly.json"
# The same settings over an in-memory 4097^2 perlin map.
echo "== pyramid: flyover 4097^2 in memory (same settings)" >&2
tv "$P/m4k_fly" "$HZ" bench --generate perlin --size 4097 --seed 1 --path flyover --lod cdlod --pixel-error 1 \
   --effects none --reference off --metrics off --frames 120 --quiet --json "$P/m4k_fly.json" > /dev/null
# The peers' 4097^2 map and flight, streamed and in memory: the same terrain both ways.
if [ -f "$PT/fractal4097.png" ]; then
  echo "== pyramid: peers' 4097^2 streamed vs in memory" >&2
  "$HZ" import "$PT/fractal4097.png" --spacing 10 --zscale 0.03 --out "$P/f4097.hzp" --quiet --json > "$P/f4097_import.json"
  tv "$P/f4097_fly" "$HZ" bench --terrain "$P/f4097.hzp" --path "$PT/flight120.csv" --frames 120 --cache-mb 512 --json > "$P/f4097_fly.json"
  tv "$P/f4097_mem" "$HZ" bench --dem "$PT/fractal4097.png" --spacing 10 --zscale 0.03 --path "$PT/flight120.csv" --fps 30 \
     --frames 120 --lod cdlod --pixel-error 1 --effects none --reference off --metrics off --quiet --json "$P/f4097_mem.json" > /dev/null
  # the selection alone, CPU time, both ways over the same cameras
  SEL="$(dirname "$HZ")/../../bench/stream_select"
  if [ -x "$SEL" ]; then
    "$SEL" --pyramid "$P/f4097.hzp" --dem "$PT/fractal4097.png" --spacing 10 --zscale 0.03 \
       --path "$PT/flight120.csv" > "$P/f4097_select.json"
  fi
fi
# The 24-tile SRTM mosaic with its ocean gaps.
if [ -d "$DATA/srtm_sierra_coast" ]; then
  echo "== pyramid: srtm_sierra_coast" >&2
  tv "$P/sierra_import" "$HZ" import "$DATA/srtm_sierra_coast" --out "$P/sierra.hzp" --quiet --json > "$P/sierra_import.json"
  "$HZ" info "$P/sierra.hzp" --json > "$P/sierra_info.json"
  "$HZ" render --terrain "$P/sierra.hzp" --camera 540000,4200,400000,60,-6 --out "$OUT/sierra_streamed.png" --json > "$P/sierra_render.json"
fi
# The same mosaic imported as 1, 2 and 4 parallel jobs (GNU parallel, --tiles / --finish), 3 runs each
# (IMPORT_JOBS=0 skips it: about 10 min on 2 idle cores).
if [ "${IMPORT_JOBS:-1}" = 1 ] && [ -d "$DATA/srtm_sierra_coast" ] && command -v parallel >/dev/null; then
  echo "== pyramid: srtm_sierra_coast as 1, 2, 4 parallel jobs" >&2
  bash bench/import_jobs.sh "$HZ" "$DATA/srtm_sierra_coast" "$P"
fi
if [ "${BIG:-0}" = 1 ]; then
  echo "== pyramid: import 65537^2 perlin (long)" >&2
  tv "$P/g64k_import" "$HZ" import --generate perlin --size 65537 --seed 1 --out "$P/g64k.hzp" --quiet --json > "$P/g64k_import.json"
  tv "$P/g64k_fly" "$HZ" bench --terrain "$P/g64k.hzp" --path flyover --cache-mb 512 --frames 120 --json > "$P/g64k_fly.json"
fi
python3 bench/pyramid_summary.py "$P" > "$OUT/pyramid.md"
cat "$OUT/pyramid.md"
