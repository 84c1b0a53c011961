#!/usr/bin/env bash
# The layering of docs/DESIGN.md (Layout), checked on the sources and on real link lines. Compilation
# already refuses most breaches (each target sees only the include directories of what it links); this
# also catches a project header reached through a library that happens to be linked, a device header
# leaking through a public header, thread or file code in the pure rooms, and a library reaching the
# pipeline or a device through a link dependency. Rules are written per folder, also for folders still
# to come (a rule for a folder that does not exist is kept and checked once it does), and every folder
# with code must have one.
# Usage: check_layering.sh SOURCE_DIR PIPELINE_PROBE_LINK_TXT SINKS_PROBE_LINK_TXT
set -uo pipefail
src=$1
pipeline_link=$2
sinks_link=$3
failures=0
checked=0
fail() { echo "layering: $*"; failures=$((failures + 1)); }

# Which project headers each folder's sources may include, by the include's first path element ("<room>/
# file.hpp"); an include without a slash is a private header of the same folder. `*`: anything.
declare -A rules=(
  # The ground floor: shared types (measurement, health, frames, the source and sink interfaces).
  [core]="core"
  # Pure rooms: functions on the cross-section, no threads, no I/O (checked below).
  [rut]="rut core"
  [trafficability]="trafficability core"  # distance, segments, the go/no-go advisory
  # pipeline/, room by room, each above the ones it names.
  [pipeline/gpu]="gpu"  # census SGM and DIC, OpenCV-free, buildable alone (scripts/build-gpu-bench)
  [pipeline/geometry]="geometry core"
  [pipeline/refinement]="refinement core"
  [pipeline/engines]="engines geometry refinement gpu core"
  [pipeline/measurement]="measurement engines geometry refinement core rut"
  [pipeline/runtime]="runtime measurement engines geometry refinement core rut"
  # drivers/: sources and sinks, each on core/ alone (never the pipeline, never each other).
  [drivers/camera]="camera core"        # source: Aravis cameras
  [drivers/synthetic]="synthetic core"  # source: the rendered scene
  [drivers/recording]="recording core"  # source (replay) and sinks (recorder, CSV)
  [drivers/gps]="gps core"              # source: positions from gpsd
  [drivers/can]="can core"              # sink: CAN bus, candump log
  [drivers/plots]="plots core"          # sink: PNG plots
  [drivers/uplink]="uplink core"        # sink: the MQTT fleet uplink
  [drivers/web]="web core"              # sink: the live web view
  # Above everything.
  [daemon]="*"
  [bench]="*"
  [tests]="*"
)
pure="rut trafficability"

check_folder() {  # folder allowed-prefixes...
  local folder=$1 allowed=$2
  [[ $allowed == "*" ]] && return
  while IFS= read -r line; do
    local file=${line%%:*}
    local inc=${line#*\"}
    inc=${inc%%\"*}
    local top=${inc%%/*}
    [[ $inc == */* ]] || continue  # a private header of the same folder
    [[ " $allowed " == *" $top "* ]] || fail "$file includes \"$inc\" ($folder may include: $allowed)"
  done < <(grep -rn '#include "' "$src/$folder" --include='*.cpp' --include='*.hpp')
}

# 1. Every folder with code has a rule (a new room gets its rule here first).
while IFS= read -r dir; do
  rel=${dir#"$src"/}
  case $rel in
    pipeline/* | drivers/*) key=$(cut -d/ -f1-2 <<<"$rel") ;;
    *) key=${rel%%/*} ;;
  esac
  [[ -n ${rules[$key]+set} ]] || fail "$rel has code but no layering rule (tests/layout/check_layering.sh)"
done < <(find "$src" \( -path "$src/build*" -o -path "$src/.git" -o -path "$src/gpu-bench" \) -prune -o \
  \( -name '*.cpp' -o -name '*.hpp' \) -printf '%h\n' | sort -u)

# 2. Each folder includes only what its rule names; folders still to come are skipped until they exist.
for folder in "${!rules[@]}"; do
  [[ -d $src/$folder ]] || continue
  check_folder "$folder" "${rules[$folder]}"
  checked=$((checked + 1))
done

# 3. The pure rooms: no threads, no files, no logging.
for folder in $pure; do
  [[ -d $src/$folder ]] || continue
  while IFS= read -r hit; do fail "pure room includes a thread or I/O header: $hit"; done < <(
    grep -rnE '#include <(thread|mutex|atomic|future|condition_variable|semaphore|stop_token|fstream|iostream|cstdio|stdio\.h|filesystem|unistd\.h|fcntl\.h|sys/|spdlog|opencv2/(imgcodecs|highgui|videoio))' \
      "$src/$folder" --include='*.cpp' --include='*.hpp')
done

# 4. Device headers stay private to their driver: no public header (any include/ folder) names them.
while IFS= read -r hit; do fail "public header includes a device header: $hit"; done < <(
  grep -rnE '#include <(arv\.h|glib\.h|glib/|gio/|libusb\.h|libusb-1\.0/|gps\.h|mosquitto\.h|httplib\.h|vulkan/)' \
    "$src" --include='*.hpp' --exclude-dir='build*' --exclude-dir=.git --exclude-dir=gpu-bench | grep '/include/')

# 5. The engine factory sits above the engines: only it (and each engine's own source) includes an
#    engine's header, and the engine interface includes neither the engines nor the factory.
while IFS= read -r line; do
  file=${line%%:*}
  inc=${line#*\"}
  inc=${inc%%\"*}
  case $(basename "$file") in
    engine_factory.cpp | "${inc%.hpp}.cpp") ;;
    *) fail "only the engine factory includes an engine: $line" ;;
  esac
done < <(grep -rnE '#include "(opencv_engines|gpu_engine)\.hpp"' "$src/pipeline" --include='*.cpp' --include='*.hpp')
while IFS= read -r hit; do fail "the engine interface includes an engine or the factory: $hit"; done < <(
  grep -nE '#include "(opencv_engines|gpu_engine|engines/engine_factory)\.hpp"' \
    "$src"/pipeline/engines/disparity_engine.cpp "$src"/pipeline/engines/include/engines/disparity_engine.hpp)

# 6. Link lines. A program that links only the pipeline links no device library; a program that links
#    only the output libraries (the CAN, CSV and plot sinks) links no pipeline library, nor the rut
#    extraction.
check_link() {  # link.txt what forbidden-regex
  if [[ ! -s $1 ]]; then
    fail "no link line at $1"
    return
  fi
  local found
  found=$(grep -oE "[^ ]*($3)[^ ]*" "$1" | sort -u | tr '\n' ' ')
  [[ -z $found ]] || fail "$2 links: $found"
}
check_link "$pipeline_link" "a program linking rutd_pipeline" 'aravis|libusb|glib|gobject|gio-2|yaml-cpp|systemd|gps|mosquitto'
check_link "$sinks_link" "a program linking only the sinks" \
  'librutd_(pipeline|runtime|measurement|engines|geometry|refinement|sgm|gpu|rut)\.a|vulkan|aravis|libusb|systemd'

if ((failures > 0)); then
  echo "layering: $failures breach(es)"
  exit 1
fi
echo "layering: $checked folders include only what they may (of ${#rules[@]} rules, the rest for folders to come);" \
  "rut/ is pure; no public header includes a device header; only the factory includes the engines;" \
  "the pipeline links no device library and the sinks no pipeline library"
