#!/usr/bin/env bash
# Builds CACHE_DIR/initramfs.cpio (newc, uncompressed: it is small and qemu loads it faster than the
# kernel would decompress it under emulation) from busybox-static, the guest init next to this script
# and the modules fetch-kernel.sh left in CACHE_DIR/kernel/modules. Rebuilt only when an input is newer.
# The host has no cpio; busybox's applet writes the archive. Exit status 77 without busybox-static (1
# under RUTD_TEST_NO_SKIP=1: tests/skip_policy.sh).
# Usage: build-initramfs.sh CACHE_DIR
set -euo pipefail

cache=${1:?usage: build-initramfs.sh CACHE_DIR}
here=$(cd "$(dirname "$0")" && pwd)
out=$cache/initramfs.cpio
busybox=${BUSYBOX:-/bin/busybox}
. "$here/../../skip_policy.sh"

# ldd fails on a static executable, which is what the initramfs needs (it has no libc).
[ -x "$busybox" ] && ! ldd "$busybox" >/dev/null 2>&1 ||
  skip_needs_installed "no static $busybox (Debian package busybox-static)"
if [ -s "$out" ] && [ "$out" -nt "$here/init" ] && [ "$out" -nt "$cache/kernel/release" ] &&
   [ "$out" -nt "$busybox" ]; then
  exit 0
fi

root=$(mktemp -d "$cache/initramfs.XXXXXX")
trap 'rm -rf "$root"' EXIT
mkdir -p "$root"/{bin,dev,proc,sys,modules}
cp "$busybox" "$root/bin/busybox"
for applet in $("$busybox" --list); do
  # A link named busybox would replace the binary itself.
  [ "$applet" = busybox ] || ln -s busybox "$root/bin/$applet"
done
cp "$here/init" "$root/init"
chmod 755 "$root/init"
cp "$cache"/kernel/modules/*.ko "$cache/kernel/modules/load-order" "$root/modules/"
(cd "$root" && find . | LC_ALL=C sort | "$busybox" cpio -o -H newc >"$out.tmp" 2>/dev/null)
mv "$out.tmp" "$out"
