#!/usr/bin/env bash
# The CI half of the skip policy, which only .ci/run exercises otherwise: with RUTD_TEST_NO_SKIP=1 a skip
# for something scripts/install-deps installs fails (exit 1) while a skip for missing hardware stays a
# skip (77); and tests/check_skips.py fails a run whose JUnit file has a skipped test that tests/ci_skips.txt
# does not list, passes one whose skips it lists, and refuses an unreadable file (2).
# Usage: check_ci_skip_policy.sh SOURCE_DIR
set -uo pipefail
src=${1:?usage: check_ci_skip_policy.sh SOURCE_DIR}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
failures=0 checks=0
expect() {  # WANT_STATUS WHAT COMMAND...
  local want=$1 what=$2 got
  shift 2
  "$@" >"$tmp/out" 2>&1
  got=$?
  checks=$((checks + 1))
  if [ "$got" != "$want" ]; then
    echo "FAILED: $what: exit $got, expected $want; output:" >&2
    sed 's/^/  /' "$tmp/out" >&2
    failures=$((failures + 1))
  fi
}
policy=". '$src/tests/skip_policy.sh'"
expect 77 "an installable prerequisite skips outside CI" \
  env -u RUTD_TEST_NO_SKIP bash -c "$policy; skip_needs_installed canmatrix"
expect 1 "an installable prerequisite fails under RUTD_TEST_NO_SKIP=1" \
  env RUTD_TEST_NO_SKIP=1 bash -c "$policy; skip_needs_installed canmatrix"
expect 77 "missing hardware still skips under RUTD_TEST_NO_SKIP=1" \
  env RUTD_TEST_NO_SKIP=1 bash -c "$policy; skip_needs_hardware 'a USB bus'"

junit() {  # FILE SKIPPED_TEST_NAME
  cat >"$1" <<XML
<?xml version="1.0" encoding="UTF-8"?>
<testsuite name="Linux-c++" tests="2" failures="0" disabled="0" skipped="1">
  <testcase name="Config.ReadsTheDefault" classname="Config.ReadsTheDefault" time="0.01" status="run">
    <system-out>ok</system-out>
  </testcase>
  <testcase name="$2" classname="$2" time="0.01" status="notrun">
    <skipped message="Skipped"/>
    <system-out>[  SKIPPED ] needs something</system-out>
  </testcase>
</testsuite>
XML
}
junit "$tmp/listed.xml" "UsbHotplugMonitor.CountsARealCameraPluggedIn"
junit "$tmp/unlisted.xml" "VehicleSpeed.DecodesCanmatrixCcvsFramesWithJ1939Ranges"
check="$src/tests/check_skips.py"
allowed="$src/tests/ci_skips.txt"
expect 0 "a skip tests/ci_skips.txt lists passes" python3 "$check" "$allowed" "$tmp/listed.xml"
expect 1 "a skip it does not list fails" python3 "$check" "$allowed" "$tmp/unlisted.xml"
expect 1 "one unlisted skip among files fails" python3 "$check" "$allowed" "$tmp/listed.xml" "$tmp/unlisted.xml"
expect 2 "an unreadable JUnit file is an error" python3 "$check" "$allowed" "$tmp/missing.xml"
if ! grep -q "NOT ALLOWED: VehicleSpeed.DecodesCanmatrixCcvsFramesWithJ1939Ranges" < <(python3 "$check" "$allowed" "$tmp/unlisted.xml" 2>&1); then
  echo "FAILED: check_skips.py does not name the unlisted skip" >&2
  failures=$((failures + 1))
fi
checks=$((checks + 1))
echo "check_ci_skip_policy: $checks checks, $failures failed"
[ "$failures" = 0 ]
