#!/usr/bin/env bash
# Draws the Olinda sample with every overlay method at three cameras (samples/olinda/cameras:
# the home view, top-down from 3 km, oblique from 1.7 km) into OUTDIR/<camera>-<method>/, and
# with --compare compares two such folders pixel for pixel (mask.png and color.png, idiff with
# no tolerance). The record of "nothing lost in the projected frame" across a change: run it
# before and after, then compare.
#
# Usage: scripts/olinda_frames.sh OUTDIR [BUILD]     (BUILD: the build folder, default build)
#        scripts/olinda_frames.sh --compare BEFORE AFTER
# Needs: overlay_render built; idiff (openimageio-tools, scripts/install-deps.sh has it).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
cameras="home topdown oblique"
if [ "${1:-}" = "--compare" ]; then
  [ $# -eq 3 ] || { sed -n '7,8p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
  differing=0
  for dir in "$3"/*/; do
    name=$(basename "$dir")
    for image in mask.png color.png; do
      if idiff -fail 0 -warn 0 -a "$2/$name/$image" "$3/$name/$image" > /dev/null 2>&1; then
        echo "$name $image: identical"
      else
        echo "$name $image: DIFFERS"
        differing=$((differing + 1))
      fi
    done
  done
  echo "$differing images differ"
  [ "$differing" -eq 0 ]
  exit
fi
[ $# -ge 1 ] || { sed -n '7,8p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
out=$1
build=${2:-build}
methods=$("$build/apps/overlay_render" --help 2>&1 | sed -n 's/^  \([a-z-]*\): .*/\1/p')
mkdir -p "$out"
for camera in $cameras; do
  for method in $methods; do
    "$build/apps/overlay_render" --scene "$root/samples/olinda/scene.json" \
      --camera "$root/samples/olinda/cameras/$camera.json" --width 600 --height 450 --method "$method" \
      --no-cache --out "$out/$camera-$method" > "$out/$camera-$method.log" 2>&1 ||
      echo "overlay_render failed: $camera $method (see $out/$camera-$method.log)" >&2
    echo "$camera $method"
  done
done
