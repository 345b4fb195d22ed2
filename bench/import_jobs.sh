#!/usr/bin/env bash
# Import wall time of the 24-tile SRTM mosaic as 1, 2 and 4 parallel jobs
# (issue 17): GNU parallel runs the import's job ranges (--tiles A-A, one
# thread each), then --finish joins them; also the one-run import (every
# core). RUNS runs each (default 3); the summary quotes medians.
# Writes DIR/import_jobs.json:
#   {"cores": N, "jobs": J, "runs": [{"mode": "parallel", "parallel": P, "s": T}, ...]}
#   usage: bench/import_jobs.sh HORIZON MOSAIC_DIR OUT_DIR
set -euo pipefail
HZ=$1 SRC=$2 DIR=$3
RUNS=${RUNS:-3}
command -v parallel >/dev/null || { echo "import_jobs.sh: GNU parallel is not installed (scripts/deps.sh)" >&2; exit 1; }
mkdir -p "$DIR"
W=$(mktemp -d "${TMPDIR:-/tmp}/hz_import_jobs.XXXXXX")
trap 'rm -rf "$W"' EXIT
J=$("$HZ" import "$SRC" --out "$W/s.hzp" --jobs)
now() { date +%s.%N; }
sec() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", b - a }'; }
rows=()
for r in $(seq 1 "$RUNS"); do
  t0=$(now)
  "$HZ" import "$SRC" --out "$W/one.hzp" --quiet
  rows+=("{\"mode\": \"one run\", \"parallel\": 1, \"threads\": $(nproc), \"s\": $(sec "$t0" "$(now)")}")
  for P in 1 2 4; do
    rm -f "$W"/s.hzp*
    t0=$(now)
    seq 0 $((J - 1)) | parallel -j "$P" "$HZ" import "$SRC" --out "$W/s.hzp" --quiet --threads 1 --tiles {}-{}
    "$HZ" import "$SRC" --out "$W/s.hzp" --finish --quiet
    t=$(sec "$t0" "$(now)")
    cmp -s "$W/one.hzp" "$W/s.hzp" || { echo "import_jobs.sh: $P parallel jobs differ from the one run" >&2; exit 1; }
    rows+=("{\"mode\": \"parallel\", \"parallel\": $P, \"threads\": 1, \"s\": $t}")
    echo "import_jobs: run $r, $P parallel jobs: $t s" >&2
  done
done
{ printf '{"source": "%s", "cores": %d, "jobs": %d, "runs": [' "$(basename "$SRC")" "$(nproc)" "$J"
  (IFS=,; printf '%s' "${rows[*]}"); printf ']}\n'; } > "$DIR/import_jobs.json"
