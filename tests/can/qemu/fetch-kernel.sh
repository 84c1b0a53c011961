#!/usr/bin/env bash
# Fetches Debian's own amd64 kernel (the versioned linux-image package that linux-image-amd64 depends
# on) into CACHE_DIR/kernel without installing it:
#   CACHE_DIR/kernel/vmlinux      uncompressed ELF kernel (qemu boots it ~2 s faster than vmlinuz)
#   CACHE_DIR/kernel/modules/*.ko the few modules the guest loads (virtio-mmio, 9p, CAN, vcan, overlay)
#   CACHE_DIR/kernel/release      the kernel release, e.g. 6.1.0-56-amd64
# Idempotent: does nothing when those exist with every module below. Exit status 77 when the kernel cannot be had here (no apt,
# no network), with the reason on stderr, so callers can skip instead of failing (1 under
# RUTD_TEST_NO_SKIP=1: tests/skip_policy.sh).
# Usage: fetch-kernel.sh CACHE_DIR
set -euo pipefail

cache=${1:?usage: fetch-kernel.sh CACHE_DIR}
out=$cache/kernel

# Modules in load order (there is no modules.dep in the guest: insmod, dependencies first). overlay: the
# systemd guest's root is the host's root under a writable tmpfs layer.
modules=(
  drivers/virtio/virtio_ring drivers/virtio/virtio drivers/virtio/virtio_mmio
  fs/netfs/netfs fs/fscache/fscache net/9p/9pnet net/9p/9pnet_virtio fs/9p/9p
  drivers/net/can/dev/can-dev net/can/can net/can/can-raw drivers/net/can/vcan
  fs/overlayfs/overlay
)
[ -s "$out/vmlinux" ] && [ -s "$out/release" ] &&
  [ "$(cat "$out/modules/load-order" 2>/dev/null)" = "$(printf '%s\n' "${modules[@]##*/}")" ] && exit 0

. "$(dirname "$0")/../../skip_policy.sh"
command -v apt-cache >/dev/null && command -v apt-get >/dev/null && command -v dpkg-deb >/dev/null ||
  skip_needs_installed "apt-get/dpkg-deb not available"
package=$(apt-cache depends linux-image-amd64 2>/dev/null | awk '/Depends: linux-image-[0-9]/ {print $2; exit}')
[ -n "$package" ] || skip_needs_installed "apt knows no linux-image-amd64 (not Debian amd64? apt-get update first?)"
release=${package#linux-image-}

work=$(mktemp -d "$cache/fetch.XXXXXX")
trap 'rm -rf "$work"' EXIT
(cd "$work" && apt-get download -q "$package" >download.log 2>&1) ||
  skip_needs_installed "apt-get download $package failed: $(tail -3 "$work/download.log")"

members=("./boot/vmlinuz-$release")
for m in "${modules[@]}"; do members+=("./lib/modules/$release/kernel/$m.ko"); done
dpkg-deb --fsys-tarfile "$work"/"$package"_*.deb | tar -x -C "$work" "${members[@]}"

# The kernel tree's scripts/extract-vmlinux approach: find the compressed payload by its magic and
# decompress from there (trailing data after the stream is expected, so ignore the exit status).
extract() {  # extract MAGIC DECOMPRESSOR...
  local magic=$1; shift
  local pos
  for pos in $(LC_ALL=C grep -abo -P "$magic" "$work/boot/vmlinuz-$release" | cut -d: -f1); do
    tail -c +$((pos + 1)) "$work/boot/vmlinuz-$release" | "$@" >"$work/vmlinux" 2>/dev/null || true
    if [ "$(head -c 4 "$work/vmlinux" | od -An -c | tr -d ' ')" = '177ELF' ]; then return 0; fi
  done
  return 1
}
extract '\xFD7zXZ\x00' xz -dc || extract '\x28\xB5\x2F\xFD' zstd -dc || extract '\x1F\x8B\x08' gzip -dc ||
  { echo "fetch-kernel: cannot find the kernel payload in vmlinuz-$release" >&2; exit 1; }

mkdir -p "$out/modules"
for m in "${modules[@]}"; do cp "$work/lib/modules/$release/kernel/$m.ko" "$out/modules/"; done
printf '%s\n' "${modules[@]##*/}" >"$out/modules/load-order"
mv "$work/vmlinux" "$out/vmlinux"
echo "$release" >"$out/release"
