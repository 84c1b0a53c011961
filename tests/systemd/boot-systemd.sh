#!/usr/bin/env bash
# rutd under a real systemd as PID 1: installs the build as `cmake --install` does (into a staging
# folder), boots Debian's kernel under qemu with the host's systemd on an overlay of the host's root
# (tests/can/qemu, RUTD_GUEST_INIT=systemd), and runs boot-job.sh there: rutd.service becomes active
# after READY=1, is restarted after kill -9, stays activating (no watchdog) while its first pair is
# stuck, is killed by the watchdog and restarted when a stage hangs once ready, stops cleanly, keeps the
# journal quiet, and keeps its hardening score. Prints the console and a table of the checks.
#
# Usage: boot-systemd.sh BUILD_DIR
# Exit status: 0 all checks passed, 1 a check failed or the guest did not run the job, 77 (skip) when
# qemu, the kernel, busybox-static or systemd cannot be had here (1 under RUTD_TEST_NO_SKIP=1:
# tests/skip_policy.sh) or the host is not amd64.
set -euo pipefail

build=$(cd "${1:?usage: boot-systemd.sh BUILD_DIR}" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
qemu_dir=$here/../can/qemu
. "$here/../skip_policy.sh"

[ -x /lib/systemd/systemd ] && command -v systemctl >/dev/null ||
  skip_needs_installed "no systemd on this machine (Debian package systemd)"
[ -x "$build/bin/rutd" ] || { echo "boot-systemd: $build/bin/rutd is not built" >&2; exit 1; }

# The job must live outside /mnt and /run (tmpfs in the guest); the build tree is seen through 9p.
work=$build/systemd-boot
rm -rf "$work"
mkdir -p "$work"
DESTDIR=$work/stage cmake --install "$build" >"$work/install.log"
tar -C "$work/stage" --owner=0 --group=0 -cf "$work/stage.tar" .
# Emulation (TCG) measures about a hundred times slower than the vehicle PC (160x120 with the default
# engine: 0.4 s a pair, next to the 0.5 s stale limit): a small image, the quickest engine, and a
# watchdog period that leaves room for an emulated CPU that the host does not always schedule (with 5 s,
# a host busy with other work made a healthy rutd miss it). Passed to the guest's unit as drop-ins.
cat >"$work/params" <<'EOF'
RUTD_OPTIONS="--size 160x120 --engine bm --no-dic"
WATCHDOG_S=10
STALL_AFTER=10
EOF
cp "$here/boot-job.sh" "$work/job.sh"
printf '#!/bin/sh\nexec /bin/sh %s %s "$@"\n' "$work/job.sh" "$work" >"$work/run-job.sh"

start=$(date +%s.%N)
status=0
RUTD_GUEST_INIT=systemd "$qemu_dir/run-guest.sh" "$build/can-qemu" "$work/run-job.sh" 400 \
  >"$work/console.log" 2>"$work/run-guest.err" || status=$?
wall=$(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }')
# 77: run-guest.sh skipped (tests/skip_policy.sh), for a reason that allows it here.
[ "$status" = 77 ] && skip_needs_hardware "$(tail -1 "$work/run-guest.err")"
tr -d '\r' <"$work/console.log" >"$work/console.txt"
cat "$work/console.txt"
cat "$work/run-guest.err" >&2

echo
echo "boot-systemd: guest run $wall s wall (boot, checks, power-off)"
grep -E '^RUTD-(FIGURE|INFO)' "$work/console.txt" || true
grep '^RUTD-CHECK' "$work/console.txt" | awk '{ printf "  %-36s %-10s %-24s %s", $2, $3, $4, $5; for (i = 6; i <= NF; i++) printf " %s", $i; print "" }'
[ "$status" = 0 ] || { echo "boot-systemd: run-guest.sh failed ($status)"; exit 1; }
grep -q '^RUTD-GUEST-EXIT=0$' "$work/console.txt" || { echo "boot-systemd: the job failed or never ran"; exit 1; }
expected=7
found=$(grep -c '^RUTD-CHECK .* PASS' "$work/console.txt" || true)
[ "$found" = "$expected" ] || { echo "boot-systemd: $found of $expected checks passed"; exit 1; }
echo "boot-systemd: all $expected checks passed"
