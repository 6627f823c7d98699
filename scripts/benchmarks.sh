#!/usr/bin/env bash
# Regenerates docs/benchmarks.md's methods table and plots: builds, runs overlay_bench --mode
# methods on Olinda at 1200 x 1000 (a few minutes on llvmpipe), and copies the table and the
# plots into docs/. Run it on an idle machine: frame times are wall time.
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build -j "$(nproc)" --target overlay_bench

out=out/benchmarks/methods
build/apps/overlay_bench --scene samples/olinda/scene.json --mode methods --frames 30 --width 1200 --height 1000 \
  --drape-sizes 512,1024,2048,4096,8192 --error-every 3 --out "$out"

mkdir -p docs/images
cp "$out/error_vs_time.svg" docs/images/methods_error_vs_time.svg
cp "$out/error_away_vs_time.svg" docs/images/methods_error_away_vs_time.svg
# The table between the markers in docs/benchmarks.md.
awk -v table="$out/methods.md" '
  /<!-- methods table begin -->/ { print; while ((getline line < table) > 0) print line; skip = 1; next }
  /<!-- methods table end -->/ { skip = 0 }
  !skip { print }
' docs/benchmarks.md > docs/benchmarks.md.new
mv docs/benchmarks.md.new docs/benchmarks.md
cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')
renderer=$(grep -m1 '"renderer"' "$out/methods.json" | cut -d'"' -f4)
sed -i "s|^\*\*Last run:\*\* .*|**Last run:** $(date -u +%Y-%m-%d); $(nproc) cores, $cpu; $renderer.|" docs/benchmarks.md
echo "benchmarks: docs/benchmarks.md and docs/images/methods_*.svg updated from $out"
