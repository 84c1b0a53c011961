# The skip policy of tests/skip_policy.hpp for the scripts that CTest runs with SKIP_RETURN_CODE 77 and
# the scripts they call. Source it, then:
#   skip_needs_hardware WHY    exit 77 (skipped): hardware or kernel support this machine lacks
#   skip_needs_installed WHY   exit 77, or exit 1 (failed) when RUTD_TEST_NO_SKIP=1 (.ci/run sets it):
#                              something scripts/install-deps installs, which CI has
#   vulkan_driver_manifests    prints the Vulkan ICD manifests the loader would find, one a line (the
#                              search of skip_policy.hpp's vulkan_driver_manifests)
# WHY goes to stderr, prefixed by the calling script's name.

skip_needs_hardware() {
  echo "${0##*/}: SKIPPED: $*" >&2
  exit 77
}

skip_needs_installed() {
  if [ "${RUTD_TEST_NO_SKIP:-}" = 1 ]; then
    echo "${0##*/}: $* [RUTD_TEST_NO_SKIP=1: CI installs this, so the skip is a failure; scripts/install-deps installs it]" >&2
    exit 1
  fi
  echo "${0##*/}: SKIPPED: $*" >&2
  exit 77
}

vulkan_driver_manifests() {
  local places=() more=() p f IFS=:
  local drivers=${VK_DRIVER_FILES:-${VK_ICD_FILENAMES:-}}
  if [ -n "$drivers" ]; then
    read -r -a places <<<"$drivers"
  else
    places=("${XDG_CONFIG_HOME:-$HOME/.config}/vulkan/icd.d")
    for p in ${XDG_CONFIG_DIRS:-/etc/xdg}; do places+=("$p/vulkan/icd.d"); done
    places+=(/etc/vulkan/icd.d "${XDG_DATA_HOME:-$HOME/.local/share}/vulkan/icd.d")
    for p in ${XDG_DATA_DIRS:-/usr/local/share:/usr/share}; do places+=("$p/vulkan/icd.d"); done
  fi
  if [ -n "${VK_ADD_DRIVER_FILES:-}" ]; then
    read -r -a more <<<"$VK_ADD_DRIVER_FILES"
    places+=("${more[@]}")
  fi
  for p in "${places[@]}"; do
    if [ -d "$p" ]; then
      for f in "$p"/*.json; do [ -f "$f" ] && echo "$f"; done
    elif [ -f "$p" ]; then
      echo "$p"
    fi
  done
  return 0
}
