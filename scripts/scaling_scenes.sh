#!/usr/bin/env bash
# Writes the scenes of overlay_bench --mode scaling into OUTDIR: one synthetic DEM (dem.tif, 4097²
# posts at 80 m, the seed paper's 327.7 km square) and per scale K a scene xK.json with K times the
# seed paper's vector load (K x 8 areas, K x 144 roads of 18,800 points per 144) over it, as
# xK_areas.gpkg and xK_roads.gpkg, and xK_globe.json: the same DEM and layers drawn on the globe
# (the DEM in UTM 33N, warped to longitude and latitude as the globe reads any CRS). The DEM is
# written once, with the first scale; the other scales only add their vectors (--vectors-only).
# 1000x is 18.8 M road points and about 650 MB of disk.
#
# Usage: scripts/scaling_scenes.sh OUTDIR [SCALES...]   (default scales: 1 10 100 1000)
# Environment:
#   SIZE=N              DEM posts a side (default 4097; e.g. 1025 for a quick try); the spacing
#                       follows, so that the square, and so the vector load's density, stays the same
#   SPACING=M           metres between posts instead (default 327680 / (SIZE - 1))
#   TERRAIN_SYNTH=PATH  the generator (default: BUILD_DIR/samples/synth/terrain_synth)
#   BUILD_DIR=DIR       the build directory to find it in (default: build/ of this repository)
# Then: overlay_bench --mode scaling --scenes OUTDIR/x1.json,OUTDIR/x10.json,... --out DIR
#       (or OUTDIR/x1_globe.json,... for the same loads on the globe)
set -euo pipefail

if [[ $# -lt 1 || "$1" == "-h" || "$1" == "--help" ]]; then
  sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//'
  [[ $# -lt 1 ]] && exit 2 || exit 0
fi
out=$1
shift
scales=("$@")
[[ ${#scales[@]} -eq 0 ]] && scales=(1 10 100 1000)
for k in "${scales[@]}"; do
  if ! [[ "$k" =~ ^[1-9][0-9]*$ ]]; then
    echo "scaling_scenes.sh: scale '$k' is not a positive whole number" >&2
    exit 2
  fi
done

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
synth=${TERRAIN_SYNTH:-${BUILD_DIR:-$repo/build}/samples/synth/terrain_synth}
if [[ ! -x "$synth" ]]; then
  echo "scaling_scenes.sh: no terrain_synth at $synth (build it: ninja terrain_synth; or set TERRAIN_SYNTH" \
    "or BUILD_DIR)" >&2
  exit 1
fi
size=${SIZE:-4097}
if ! [[ "$size" =~ ^[0-9]+$ ]] || ((size < 33)); then
  echo "scaling_scenes.sh: SIZE '$size' is not a DEM size (33 or more posts)" >&2
  exit 2
fi
spacing=${SPACING:-$((327680 / (size - 1)))}

mkdir -p "$out"
dem="$out/dem.tif"
common=(--out "$dem" --size "$size" --spacing "$spacing" --seed 7 --relief 1500 --no-holes)
first=1
for k in "${scales[@]}"; do
  scene="$out/x$k.json"
  # The first scale writes the DEM; the others keep it (the same options, so the same DEM).
  if ((first)); then
    "$synth" "${common[@]}" --scene "$scene" --vector-scale "$k"
    first=0
  else
    "$synth" "${common[@]}" --scene "$scene" --vector-scale "$k" --vectors-only
  fi
  # The same scene on the globe: its frame said, its name told apart.
  sed -e '1a\  "frame": "globe",' -e 's/\("name": ".*\)",$/\1, on the globe",/' "$scene" > "$out/x${k}_globe.json"
done

echo "DEM: $dem ($size x $size posts, $spacing m)"
ls -l "$dem"
for k in "${scales[@]}"; do
  echo "scene x$k: $out/x$k.json (on the globe: $out/x${k}_globe.json)"
  ls -l "$out/x$k.json" "$out/x${k}_globe.json" "$out/x${k}"_*.gpkg
done
