#!/usr/bin/env bash
# Runs every libFuzzer target (fuzz/) for SECONDS each, two at a time, from
# its seed corpus in fuzz/corpus/<name> (read only: new inputs go to
# BUILD/fuzz-work/<name>, crashes to BUILD/fuzz-artifacts/). Prints runs and
# seconds per target; fails if any target finds a crash, leak, timeout or
# out-of-memory. A crash found is a regression input: add it to the seed
# corpus once fixed.
# usage: scripts/fuzz.sh BUILD_DIR SECONDS
set -uo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "${1:?usage: fuzz.sh BUILD_DIR SECONDS}" && pwd)"
secs="${2:?usage: fuzz.sh BUILD_DIR SECONDS}"
targets=(dem hzt path forest_csv view_config view_script pyramid cityjson scene blob footprints imagery model)
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:strict_string_checks=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
mkdir -p "$build/fuzz-artifacts" "$build/fuzz-logs"
work="$(mktemp -d "${TMPDIR:-/tmp}/hz_fuzz.XXXXXX")"
trap 'rm -rf "$work"' EXIT
run() {
  local t=$1 exe="$build/fuzz/fuzz_$1"
  if [ ! -x "$exe" ]; then
    echo "fuzz_$t: not built (make fuzzers)" > "$build/fuzz-logs/$t.log"
    return 2
  fi
  mkdir -p "$build/fuzz-work/$t"
  # -close_fd_mask=2: the parsers' own error messages are not printed
  # (libFuzzer and sanitizer reports still are). -rss_limit_mb: an input
  # that makes a parser take more is a finding. -timeout: a hang is one.
  # fuzz_model: assimp's own leaks on malformed files are not horizon's
  # (fuzz/model.supp says why they can be told apart).
  local lsan=""
  [ "$t" = model ] && lsan="suppressions=$root/fuzz/model.supp"
  LSAN_OPTIONS="$lsan" TMPDIR="$work" "$exe" -max_total_time="$secs" -timeout=10 -rss_limit_mb=1024 -malloc_limit_mb=1024 \
    -close_fd_mask=2 -print_final_stats=1 -artifact_prefix="$build/fuzz-artifacts/$t-" \
    "$build/fuzz-work/$t" "$root/fuzz/corpus/$t" > "$build/fuzz-logs/$t.log" 2>&1
}
status=0
for ((k = 0; k < ${#targets[@]}; k += 2)); do
  pids=()
  for t in "${targets[@]:k:2}"; do
    run "$t" &
    pids+=($!)
  done
  i=0
  for t in "${targets[@]:k:2}"; do
    if wait "${pids[$i]}"; then res=ok; else res=FAILED; status=1; fi
    i=$((i + 1))
    log="$build/fuzz-logs/$t.log"
    runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
    took=$(sed -n 's/^Done [0-9]* runs in \([0-9]*\) second.*/\1/p' "$log" | tail -1)
    cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1)
    printf 'fuzz_%-12s %-6s %10s runs in %4s s (%s, %s)\n' "$t" "$res" "${runs:-?}" "${took:-?}" "${cov:-cov: ?}" \
      "corpus fuzz/corpus/$t" >&2
    if [ "$res" = FAILED ]; then
      echo "---- $log (tail)" >&2
      tail -40 "$log" >&2
    fi
  done
done
exit $status
