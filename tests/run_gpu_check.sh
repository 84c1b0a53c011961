#!/usr/bin/env bash
# Runs rutd-gpu-check (pipeline/gpu/tools/) as a CTest test under the skip policy (tests/skip_policy.sh):
# its exit status 77, no usable Vulkan device, is a skip only where no Vulkan driver is installed at all
# (a missing package: a failure in CI, which has lavapipe); with a driver installed it is a failure.
# Usage: run_gpu_check.sh RUTD_GPU_CHECK [ARGS...]
set -uo pipefail
. "$(dirname "$0")/skip_policy.sh"

"$@"
status=$?
[ "$status" = 77 ] || exit "$status"
drivers=$(vulkan_driver_manifests | paste -s -d' ')
[ -n "$drivers" ] ||
  skip_needs_installed "needs a Vulkan driver (Debian package mesa-vulkan-drivers: lavapipe runs the GPU engine on the CPU)"
echo "run_gpu_check: no usable Vulkan device, though a Vulkan driver is installed ($drivers): the GPU path is broken, not absent" >&2
exit 1
