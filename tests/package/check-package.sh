#!/usr/bin/env bash
# The Debian package of a build (packaging/deb.cmake), checked against Debian's own tools: CPack makes
# it from BUILD_DIR, then
#   - lintian reports no error (warnings and information are printed; the accepted ones are overridden
#     with their reasons in packaging/lintian-overrides);
#   - every shared library the program needs (readelf's NEEDED entries, resolved by ldd on this machine)
#     belongs to a package (dpkg -S) that the Depends field names: the dependencies dpkg-shlibdeps
#     computed cover what the binary loads;
#   - /etc/rutd/rutd.yaml is a conffile and the files a vehicle needs are in it;
#   - the version is the build's (project version and RUTD_PACKAGE_REVISION), and the packaged program
#     prints it with `rutd --version`.
# Prints one line per check. Usage: check-package.sh BUILD_DIR. Exit 0 all passed, 1 a check failed,
# 77 (skip) without dpkg-dev or lintian (1 under RUTD_TEST_NO_SKIP=1: tests/skip_policy.sh).
set -euo pipefail
build=$(cd "${1:?usage: check-package.sh BUILD_DIR}" && pwd)
. "$(dirname "$0")/../skip_policy.sh"
for tool in dpkg-shlibdeps lintian cpack readelf; do
  command -v "$tool" >/dev/null || skip_needs_installed "needs $tool (Debian packages dpkg-dev, lintian, binutils)"
done

out=$build/package-check
rm -rf "$out"
mkdir -p "$out"
(cd "$build" && cpack -G DEB -D CPACK_OUTPUT_FILE_PREFIX="$out" >"$out/cpack.log" 2>&1) ||
  { cat "$out/cpack.log"; echo "check-package: cpack failed"; exit 1; }
deb=$(ls "$out"/rutd_*.deb)
failed=0
check() {  # check NAME OK(0|1) DETAIL
  if [ "$2" = 1 ]; then echo "PASS $1: $3"; else echo "FAIL $1: $3"; failed=1; fi
}

echo "== $(basename "$deb")"
dpkg-deb --info "$deb" | sed -n 's/^ \([A-Z][A-Za-z-]*:\)/  \1/p'

# lintian: no error.
status=0
lintian --display-info --pedantic --tag-display-limit 0 --fail-on error "$deb" >"$out/lintian.txt" 2>&1 || status=$?
sed 's/^/  /' "$out/lintian.txt" | grep -v 'running with root privileges' || true
errors=$(grep -c '^E: ' "$out/lintian.txt" || true)
check lintian "$([ "$status" = 0 ] && [ "$errors" = 0 ] && echo 1 || echo 0)" "exit $status, $errors errors"

# The computed dependencies cover every library the program loads directly.
mkdir -p "$out/root"
dpkg-deb --extract "$deb" "$out/root"
depends=$(dpkg-deb --field "$deb" Depends)
needed=$(readelf -d "$out/root/usr/bin/rutd" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p')
# The package that ships a library file: dpkg knows it under /lib or /usr/lib, whichever the package
# names (Debian 12's merged /usr makes both paths the same file).
owner_of() {
  local real
  real=$(realpath "$1")
  for p in "$1" "$real" "${1#/usr}" "/usr${1#/usr}" "${real#/usr}" "/usr${real#/usr}"; do
    dpkg -S "$p" 2>/dev/null | head -1 | cut -d: -f1 && return 0
  done
}
missing=()
n=0
for soname in $needed; do
  path=$(ldd "$out/root/usr/bin/rutd" | awk -v s="$soname" '$1 == s { print $3 }')
  owner=$([ -n "$path" ] && owner_of "$path" || true)
  # The package, or a name it provides (libspdlog1.10 provides the libspdlog1.10-fmt9 its shlibs names).
  names=$([ -n "$owner" ] && { echo "$owner"; dpkg-query -W -f='${Provides}' "$owner" | tr ',' '\n' | sed 's/^ *//; s/ .*//'; })
  if [ -z "$owner" ] || ! printf '%s\n' "$depends" | tr ',|' '\n\n' | sed 's/^ *//; s/[ (:].*//' | grep -qxF "$names"; then
    missing+=("$soname(${owner:-no package})")
  fi
  n=$((n + 1))
done
check shlibdeps "$([ "$n" -gt 5 ] && [ ${#missing[@]} = 0 ] && echo 1 || echo 0)" \
  "$n NEEDED libraries, each from a package in Depends${missing[*]:+; not covered: ${missing[*]}}"

# The conffile and the files of a vehicle install.
conffiles=$(dpkg-deb --ctrl-tarfile "$deb" | tar -xO ./conffiles)
files=$(dpkg-deb --contents "$deb" | awk '{ print $6 }')
absent=()
for f in ./usr/bin/rutd ./etc/rutd/rutd.yaml ./lib/systemd/system/rutd.service ./usr/lib/sysusers.d/rutd.conf \
    ./usr/lib/tmpfiles.d/rutd.conf ./lib/udev/rules.d/60-rutd-usb3vision.rules ./usr/lib/sysctl.d/60-rutd-gige.conf \
    ./usr/share/rutd/rutd.dbc ./usr/share/doc/rutd/README.md ./usr/share/doc/rutd/copyright \
    ./usr/share/doc/rutd/changelog.Debian.gz ./usr/share/man/man1/rutd.1.gz; do
  printf '%s\n' "$files" | grep -qx "$f" || absent+=("$f")
done
check contents "$([ "$conffiles" = /etc/rutd/rutd.yaml ] && [ ${#absent[@]} = 0 ] && echo 1 || echo 0)" \
  "conffiles: $conffiles${absent[*]:+; absent: ${absent[*]}}"
grep -q '^ExecStart=/usr/bin/rutd run --config /etc/rutd/rutd.yaml$' "$out/root/lib/systemd/system/rutd.service" &&
  unit=1 || unit=0
check unit "$unit" "ExecStart: $(sed -n 's/^ExecStart=//p' "$out/root/lib/systemd/system/rutd.service")"

# The version: the build's, in the control file and in the program.
# The version, from its one source (project() in CMakeLists.txt) and the build's revision.
cache() { sed -n "s/^$1:[A-Z]*=//p" "$build/CMakeCache.txt"; }
project=$(sed -n 's/^project(rutd VERSION \([0-9.]*\).*/\1/p' "$(cache CMAKE_HOME_DIRECTORY)/CMakeLists.txt")
want="$project-$(cache RUTD_PACKAGE_REVISION)"
version=$(dpkg-deb --field "$deb" Version)
printed=$("$out/root/usr/bin/rutd" --version)
check version "$([ "$version" = "$want" ] && case $printed in "rutd $want "*) echo 1 ;; *) echo 0 ;; esac)" \
  "Version $version (build: $want), rutd --version: $printed"

exit "$failed"
