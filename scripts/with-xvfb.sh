#!/usr/bin/env bash
# with-xvfb.sh CMD ARGS...: runs CMD with DISPLAY set to a private Xvfb server.
#
# Unlike `xvfb-run -a`, two of these can start at the same moment (ctest -j):
# Xvfb itself picks a free display number (-displayfd) instead of the script
# guessing one, and -noreset keeps the server up between a test's windows.
set -euo pipefail
if [ $# -eq 0 ]; then echo "usage: with-xvfb.sh CMD [ARGS...]" >&2; exit 2; fi
command -v Xvfb >/dev/null || { echo "with-xvfb: Xvfb not found (scripts/deps.sh installs xvfb)" >&2; exit 1; }
dir=$(mktemp -d)
trap 'kill "$xpid" 2>/dev/null || true; wait "$xpid" 2>/dev/null || true; rm -rf "$dir"' EXIT
mkfifo "$dir/fd"
Xvfb -displayfd 3 -screen 0 "${XVFB_SCREEN:-1280x1024x24}" -nolisten tcp -noreset 3>"$dir/fd" 2>"$dir/log" &
xpid=$!
num=""
if ! read -r -t 30 num <"$dir/fd" || [ -z "$num" ]; then
  echo "with-xvfb: Xvfb did not start: $(tail -c 400 "$dir/log")" >&2
  exit 1
fi
export DISPLAY=":$num"
set +e
"$@"
rc=$?
exit $rc
