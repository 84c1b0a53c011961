#!/usr/bin/env bash
# The layering of docs/DESIGN.md (Layout), checked on the sources and on a real link line:
#   rut <- core <- {pipeline, drivers/can, drivers/camera, drivers/recording, drivers/synthetic} <- daemon
# Compilation already refuses most breaches (each target sees only the include directories of what it
# links); this also catches a device header leaking through a public header, and a device library
# reaching the pipeline through a link dependency.
# Usage: check_layering.sh SOURCE_DIR PIPELINE_PROBE_LINK_TXT
set -uo pipefail
src=$1
link_txt=$2
failures=0
fail() { echo "layering: $*"; failures=$((failures + 1)); }

# 1. Device headers stay private to drivers/camera: no public header (any include/ folder) names them.
while IFS= read -r hit; do fail "public header includes a device header: $hit"; done < <(
  grep -rnE '#include <(arv\.h|glib\.h|glib/|gio/|libusb\.h|libusb-1\.0/)' "$src" --include='*.hpp' |
    grep '/include/')

# 2. Which project headers each folder may include, by the include's first path element.
check_folder() {  # folder allowed-prefixes...
  local folder=$1; shift
  local allowed="$*"
  while IFS= read -r line; do
    local file=${line%%:*}
    local inc=${line#*\"}; inc=${inc%%\"*}
    local top=${inc%%/*}
    [[ $inc == */* ]] || continue  # a private header of the same folder
    [[ " $allowed " == *" $top "* ]] || fail "$file includes \"$inc\" ($folder may include: $allowed)"
  done < <(grep -rn '#include "' "$src/$folder" --include='*.cpp' --include='*.hpp')
}
check_folder rut rut core
check_folder core core
check_folder pipeline geometry refinement engines measurement runtime gpu core rut  # gpu: the Vulkan matcher, pipeline/gpu/
check_folder drivers/can can core rut pipeline          # pipeline: can_sink.* only, checked below
check_folder drivers/camera camera core rut
check_folder drivers/recording recording core rut pipeline  # pipeline: measurement_csv_sink.hpp only
check_folder drivers/synthetic synthetic core rut
check_folder drivers/plots plots core rut pipeline  # pipeline: plot_sink.* only
while IFS= read -r line; do
  case ${line%%:*} in
    */can_sink.hpp | */can_sink.cpp | */measurement_csv_sink.hpp | */plot_sink.hpp | */plot_sink.cpp) ;;
    *) fail "only the measurement-sink adapters of drivers/ include pipeline/: $line" ;;
  esac
done < <(grep -rn '#include "pipeline/' "$src/drivers" --include='*.cpp' --include='*.hpp')

# 3. A program that links only the pipeline library links no device library.
if [[ ! -s $link_txt ]]; then
  fail "no link line at $link_txt"
else
  devices='aravis|libusb|glib|gobject|gio-2|yaml-cpp|systemd'
  found=$(grep -oE "[^ ]*($devices)[^ ]*" "$link_txt" | sort -u | tr '\n' ' ')
  [[ -z $found ]] || fail "a program linking rutd_pipeline links device libraries: $found"
fi

if ((failures > 0)); then
  echo "layering: $failures breach(es)"
  exit 1
fi
echo "layering: rut, core, pipeline and the five driver libraries include only what they may;" \
  "no public header includes a device header; the pipeline links no device library"
