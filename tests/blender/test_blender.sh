#!/usr/bin/env bash
# Blender import of a run, end to end (issue 17 item 3): writes a short run of the default scene
# with the sandmpm program, imports it in Blender in background mode and checks it
# (tests/blender/check_import.py). Needs Debian's `blender` (not installed by scripts/install-deps.sh:
# it is heavy; CTest registers test_blender only where CMake found it).
#   tests/blender/test_blender.sh SANDMPM_PROGRAM [BLENDER]
set -euo pipefail
BIN=$1
BLENDER=${2:-blender}
HERE=$(cd "$(dirname "$0")" && pwd)
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
"$BIN" run --quality test --frames 3 --out "$TMP/run" >/dev/null
status=0
"$BLENDER" --background --factory-startup --python-exit-code 1 --python "$HERE/check_import.py" -- "$TMP/run" \
    >"$TMP/log" 2>&1 || status=$?
grep -E "^(ok|FAIL|check_import)|Error|Traceback" "$TMP/log" || cat "$TMP/log"
exit $status
