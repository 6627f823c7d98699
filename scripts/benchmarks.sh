#!/usr/bin/env bash
# Regenerates docs/benchmarks.md's tables and plots (about an hour on llvmpipe, 2 cores):
# - Olinda: overlay_bench --mode methods and --mode ablation at 1200 x 1000;
# - the paper-scale synthetic scene (scripts/paper_scale_scenes.sh): methods and ablation at
#   1200 x 1000, methods at 1920 x 1080 with MSAA 4x;
# - frame time against DEM size (1025², 4097², 16385² under the same vectors) and against the
#   vector load (1x, 10x, 100x the paper's on the 16385² DEM): --mode scaling;
# - 1x to 1000x the paper's load on the 4097² DEM (scripts/scaling_scenes.sh): start time, memory
#   and frames of the view-dependent tiles against terrain only: --mode scaling.
# Run it on an idle machine: frame times are wall time (ratios come from one run).
# --docs-only: only copy the results already in out/benchmarks into docs/.
set -euo pipefail
cd "$(dirname "$0")/.."
o=out/benchmarks
p=out/paper_scale

if [[ "${1:-}" != "--docs-only" ]]; then
bash scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build -j "$(nproc)" --target overlay_bench terrain_synth
bash scripts/paper_scale_scenes.sh build

bench=build/apps/overlay_bench
"$bench" --scene samples/olinda/scene.json --mode methods --frames 30 --width 1200 --height 1000 \
  --texture-sizes drape=512,1024,2048,4096,8192 --texture-sizes drape-tiles=256,512 --error-every 3 --out "$o/methods"
"$bench" --scene samples/olinda/scene.json --mode ablation --frames 30 --width 1200 --height 1000 \
  --error-every 3 --out "$o/ablation"
"$bench" --scene "$p/dem_16385_x1.json" --mode methods --frames 30 --width 1200 --height 1000 \
  --texture-sizes drape=1024,4096,8192 --texture-sizes drape-tiles=256,512 --error-every 3 --out "$o/paper"
"$bench" --scene "$p/dem_16385_x1.json" --mode ablation --frames 30 --width 1200 --height 1000 \
  --error-every 3 --out "$o/paper_ablation"
"$bench" --scene "$p/dem_16385_x1.json" --mode methods --frames 15 --width 1920 --height 1080 --msaa 4 \
  --texture-sizes drape=4096 --texture-sizes drape-tiles=256,512 --error-every 3 --out "$o/paper_1080_msaa4"
"$bench" --mode scaling --scenes "$p/dem_1025_x1.json,$p/dem_4097_x1.json,$p/dem_16385_x1.json" \
  --frames 30 --width 1200 --height 1000 --error-every 5 --out "$o/scaling_dem"
"$bench" --mode scaling --scenes "$p/dem_16385_x1.json,$p/dem_16385_x10.json,$p/dem_16385_x100.json" \
  --frames 30 --width 1200 --height 1000 --error-every 5 --out "$o/scaling_vectors"
bash scripts/scaling_scenes.sh out/scaling 1 10 100 1000
"$bench" --mode scaling --scenes out/scaling/x1.json,out/scaling/x10.json,out/scaling/x100.json,out/scaling/x1000.json \
  --frames 9 --error-every 100 --out "$o/scaling_tiles"
fi

mkdir -p docs/images
cp "$o/methods/methods_error_vs_time.svg" docs/images/methods_error_vs_time.svg
cp "$o/methods/methods_error_away_vs_time.svg" docs/images/methods_error_away_vs_time.svg
cp "$o/paper/methods_error_away_vs_time.svg" docs/images/paper_error_away_vs_time.svg
cp "$o/scaling_dem/scaling_time_vs_dem.svg" docs/images/scaling_time_vs_dem.svg
cp "$o/scaling_vectors/scaling_time_vs_vertices.svg" docs/images/scaling_time_vs_vertices.svg
for f in first_frame_cold_vs_vertices first_frame_warm_vs_vertices frame_ratio_vs_vertices peak_rss_vs_vertices; do
  cp "$o/scaling_tiles/scaling_$f.svg" "docs/images/scaling_tiles_$f.svg"
done
# The tables between their markers in docs/benchmarks.md.
replace_table() {
  awk -v table="$2" -v begin="<!-- $1 table begin -->" -v end="<!-- $1 table end -->" '
    $0 == begin { print; while ((getline line < table) > 0) print line; skip = 1; next }
    $0 == end { skip = 0 }
    !skip { print }
  ' docs/benchmarks.md > docs/benchmarks.md.new
  mv docs/benchmarks.md.new docs/benchmarks.md
}
replace_table methods "$o/methods/methods.md"
replace_table ablation "$o/ablation/ablation.md"
replace_table paper "$o/paper/methods.md"
replace_table paper-ablation "$o/paper_ablation/ablation.md"
replace_table paper-1080 "$o/paper_1080_msaa4/methods.md"
replace_table scaling-dem "$o/scaling_dem/scaling.md"
replace_table scaling-vectors "$o/scaling_vectors/scaling.md"
replace_table scaling-tiles "$o/scaling_tiles/scaling.md"
cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')
renderer=$(grep -m1 '"renderer"' "$o/methods/methods.json" | cut -d'"' -f4)
sed -i "s|^\*\*Last run:\*\* .*|**Last run:** $(date -u +%Y-%m-%d); $(nproc) cores, $cpu; $renderer.|" docs/benchmarks.md
echo "benchmarks: docs/benchmarks.md and docs/images/*.svg updated from $o"
