#!/usr/bin/env bash
# The unit tests once more in the AddressSanitizer + UndefinedBehaviorSanitizer
# build (make test runs this after the normal tests). Any report fails the
# test: ASan and UBSan abort on the first error (-fno-sanitize-recover),
# LeakSanitizer is on. Suppressed: only leaks entirely inside Mesa/X11
# (tests/san/lsan.supp, explained there). The program-level scripts test_cli,
# test_view_window, test_harden and test_polish (minutes of whole-program runs)
# are left to the normal build to keep make test short; their parsers are
# fuzzed instead.
# test_progress_cli (generating 4097^2 and 8193^2 maps to watch progress lines
# arrive: 40 s under ASan) is left out too: the progress lines'
# logic runs here in the unit test test_progress.
# usage: scripts/test-san.sh BUILD_DIR [ctest args...]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "${1:?usage: test-san.sh BUILD_DIR}" && pwd)"
shift
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:detect_stack_use_after_return=1:strict_string_checks=1:check_initialization_order=1:strict_init_order=1"
export LSAN_OPTIONS="suppressions=$root/tests/san/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
# Mesa unloads its driver when the last X display closes, after which its
# leaks come from an "<unknown module>"; pinning it keeps them attributable
# (see tests/san/keep_dri.c).
dri="$(ls /usr/lib/*/dri/swrast_dri.so /usr/lib*/dri/swrast_dri.so 2>/dev/null | head -1 || true)"
if [ -n "$dri" ] && [ -f "$build/tests/san/libhz_keep_dri.so" ]; then
  export HZ_SAN_KEEP_DRI="$dri"
  export LD_PRELOAD="$build/tests/san/libhz_keep_dri.so${LD_PRELOAD:+:$LD_PRELOAD}"
fi
echo "== unit tests under ASan + UBSan ($build)" >&2
cd "$build"
# test_http (pyramids over HTTP: loader threads, libcurl, disk cache) runs with
# LeakSanitizer off (tests/cli/CMakeLists.txt says why).
ctest --output-on-failure -j"${JOBS:-2}" -E '^(test_cli|test_view_window|test_harden|test_polish|test_progress_cli)$' "$@"
