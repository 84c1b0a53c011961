# Cross-building rutd for Debian arm64 (64-bit ARM vehicle PCs, NVIDIA Jetson boards) with Debian's cross
# toolchain (crossbuild-essential-arm64) and the arm64 -dev packages installed through multiarch, as in
# the chroot scripts/cross-chroot makes. `scripts/package --arch arm64` uses this file.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
# Multiarch: the target's libraries, pkg-config files and CMake package files are in
# /usr/lib/aarch64-linux-gnu of this same root, the architecture-independent headers are shared; no
# sysroot. Programs run at build time (glslc) are the build machine's.
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
set(PKG_CONFIG_EXECUTABLE aarch64-linux-gnu-pkg-config CACHE FILEPATH "pkg-config for arm64 (pkgconf:arm64)")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
