#!/usr/bin/env bash
# Regenerates docs/benchmarks.md's tables and plots: builds, runs overlay_bench --mode methods
# and --mode ablation on Olinda at 1200 x 1000 (a few minutes on llvmpipe), and copies the
# tables and the plots into docs/. Run it on an idle machine: frame times are wall time.
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build -j "$(nproc)" --target overlay_bench

out=out/benchmarks/methods
build/apps/overlay_bench --scene samples/olinda/scene.json --mode methods --frames 30 --width 1200 --height 1000 \
  --drape-sizes 512,1024,2048,4096,8192 --error-every 3 --out "$out"

ablation=out/benchmarks/ablation
build/apps/overlay_bench --scene samples/olinda/scene.json --mode ablation --frames 30 --width 1200 --height 1000 \
  --error-every 3 --out "$ablation"

mkdir -p docs/images
cp "$out/methods_error_vs_time.svg" docs/images/methods_error_vs_time.svg
cp "$out/methods_error_away_vs_time.svg" docs/images/methods_error_away_vs_time.svg
# The tables between their markers in docs/benchmarks.md.
replace_table() {
  awk -v table="$2" -v begin="<!-- $1 table begin -->" -v end="<!-- $1 table end -->" '
    $0 == begin { print; while ((getline line < table) > 0) print line; skip = 1; next }
    $0 == end { skip = 0 }
    !skip { print }
  ' docs/benchmarks.md > docs/benchmarks.md.new
  mv docs/benchmarks.md.new docs/benchmarks.md
}
replace_table methods "$out/methods.md"
replace_table ablation "$ablation/ablation.md"
cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')
renderer=$(grep -m1 '"renderer"' "$out/methods.json" | cut -d'"' -f4)
sed -i "s|^\*\*Last run:\*\* .*|**Last run:** $(date -u +%Y-%m-%d); $(nproc) cores, $cpu; $renderer.|" docs/benchmarks.md
echo "benchmarks: docs/benchmarks.md and docs/images/methods_*.svg updated from $out"
