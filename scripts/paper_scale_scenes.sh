#!/usr/bin/env bash
# Writes the synthetic scenes of the benchmark (docs/benchmarks.md) into out/paper_scale/:
# the seed paper's configuration (a 20 m DEM of 16385 x 16385 posts, 327.7 km square — the
# paper's was 14997 x 17556 posts, 263 M against our 268 M — with 8 habitation areas of 1,208
# points and 144 roads of 18,800 points), the same load over DEMs of 1025² and 4097² posts on the
# same square (320 m and 80 m posts), and 10x, 100x (and with --with-1000x 1000x) the vector load
# on the 16385² DEM. About 3 minutes and 2 GB of disk; the 1000x load adds 18.8 M road points.
# Usage: scripts/paper_scale_scenes.sh [build dir] [--with-1000x]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
synth="$build/samples/synth/terrain_synth"
dir=out/paper_scale
mkdir -p "$dir"
common=(--seed 7 --relief 1500 --no-holes)
for size in 1025 4097 16385; do
  spacing=$((327680 / (size - 1)))
  dem="$dir/dem_$size.tif"
  if [[ -f "$dem" ]]; then
    "$synth" --out "$dem" --size "$size" --spacing "$spacing" "${common[@]}" \
      --scene "$dir/dem_${size}_x1.json" --vector-scale 1 --vectors-only
  else
    "$synth" --out "$dem" --size "$size" --spacing "$spacing" "${common[@]}" \
      --scene "$dir/dem_${size}_x1.json" --vector-scale 1
  fi
done
scales=(10 100)
[[ " $* " == *" --with-1000x "* ]] && scales+=(1000)
for k in "${scales[@]}"; do
  "$synth" --out "$dir/dem_16385.tif" --size 16385 --spacing 20 "${common[@]}" \
    --scene "$dir/dem_16385_x$k.json" --vector-scale "$k" --vectors-only
done
echo "paper-scale scenes in $dir"
