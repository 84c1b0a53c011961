#!/usr/bin/env bash
# Boots Debian's kernel under qemu (microvm machine) with the host's root shared read-only and runs
# JOB (a /bin/sh script on the host file system: absolute path, not under /mnt or /run, which are fresh
# tmpfs in the guest) inside the guest as root, chrooted into the host root, with vcan0 up (see the
# guest's init). The guest's serial console is copied to stdout; it starts the job's part with
# RUTD-GUEST-START uptime_s=<guest seconds since boot> and ends with RUTD-GUEST-EXIT=<job status>.
#
# Usage: run-guest.sh CACHE_DIR JOB [TIMEOUT_S]
# With RUTD_GUEST_INIT=systemd the guest boots the host's systemd as PID 1 instead, on an overlay root
# (see init): JOB runs `--setup` chrooted before systemd starts, then as a unit of multi-user.target.
#   CACHE_DIR  where the kernel and the initramfs are kept between runs (fetched or built on first use)
#   TIMEOUT_S  wall-clock limit for one boot, default 90
# Environment: RUTD_TSC_KHZ  the host's TSC rate in kHz, passed to the guest as tsc_early_khz= (without
#              it about one boot in ten hangs in clock calibration under emulation), with
#              tsc=reliable (else the clocksource watchdog of a slow emulated guest may demote the TSC
#              to jiffies: 4 ms timestamps in candump); default from /proc/cpuinfo.
# Exit status: 0 when the guest ran the job and powered off (whatever the job's status: read it from
# the console), 77 when the host is not amd64, or qemu, the kernel or busybox-static cannot be had here
# (tests/skip_policy.sh: 1 for the last three under RUTD_TEST_NO_SKIP=1), 124 on timeout, else 1.
set -euo pipefail

cache=${1:?usage: run-guest.sh CACHE_DIR JOB [TIMEOUT_S]}
job=${2:?usage: run-guest.sh CACHE_DIR JOB [TIMEOUT_S]}
timeout_s=${3:-90}
here=$(cd "$(dirname "$0")" && pwd)
. "$here/../../skip_policy.sh"

qemu=$(command -v qemu-system-x86_64 || true)
[ -n "$qemu" ] || skip_needs_installed "no qemu-system-x86_64 (Debian package qemu-system-x86)"
[ "$(uname -m)" = x86_64 ] || skip_needs_hardware "the guest kernel is amd64; host is $(uname -m)"
case $job in
  /mnt/* | /run/*) echo "run-guest: JOB must not be under /mnt or /run (fresh tmpfs in the guest)" >&2; exit 1 ;;
  /*) ;;
  *) echo "run-guest: JOB must be an absolute path" >&2; exit 1 ;;
esac
[ -r "$job" ] || { echo "run-guest: cannot read $job" >&2; exit 1; }
case $job in *[[:space:]]*) echo "run-guest: JOB path must not contain spaces" >&2; exit 1 ;; esac

mkdir -p "$cache"
# One preparer at a time (ctest may run the qemu tests in parallel).
exec 9>"$cache/.lock"
flock 9
"$here/fetch-kernel.sh" "$cache"
"$here/build-initramfs.sh" "$cache"
flock -u 9

tsc_khz=${RUTD_TSC_KHZ:-$(awk -F': *' '/^cpu MHz/ {printf "%d", $2 * 1000; exit}' /proc/cpuinfo)}
append="console=ttyS0 quiet panic=-1 rdinit=/init rutd.job=$job"
memory=512
cpus=1
if [ "${RUTD_GUEST_INIT:-}" = systemd ]; then
  append="$append rutd.init=systemd systemd.show_status=false"
  memory=1024
  cpus=2
fi
[ -n "$tsc_khz" ] && [ "$tsc_khz" -gt 0 ] && append="$append tsc_early_khz=$tsc_khz tsc=reliable"

# Hardware virtualisation only where the host kernel drives it itself; a nested /dev/kvm provided by
# another hypervisor may not run this kernel.
accel=(-accel tcg)
if [ -w /dev/kvm ] && { [ -d /sys/module/kvm_intel ] || [ -d /sys/module/kvm_amd ]; }; then
  accel=(-accel kvm -cpu host)
fi

# microvm: no PCI or firmware to probe; ACPI on so that poweroff ends qemu instead of halting it.
status=0
timeout --kill-after=5 "$timeout_s" "$qemu" \
  -M microvm,acpi=on -m "$memory" -smp "$cpus" "${accel[@]}" \
  -nodefaults -no-user-config -display none -no-reboot \
  -chardev stdio,id=console,signal=off -serial chardev:console \
  -kernel "$cache/kernel/vmlinux" -initrd "$cache/initramfs.cpio" -append "$append" \
  -fsdev local,id=hostroot,path=/,security_model=none,readonly=on,multidevs=remap \
  -device virtio-9p-device,fsdev=hostroot,mount_tag=hostroot \
  </dev/null || status=$?
case $status in
  0) exit 0 ;;
  124 | 137) echo "run-guest: the guest did not power off within $timeout_s s" >&2; exit 124 ;;
  *) echo "run-guest: qemu exited with status $status" >&2; exit 1 ;;
esac
