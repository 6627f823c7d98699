#!/usr/bin/env bash
# Sets everything up and runs the main job: the terrain viewer on the Olinda sample. Where there
# is no display, renders the same scene headless to a PNG and prints where it is.
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build -j "$(nproc)" --target terrain_viewer overlay_render

scene=samples/olinda/scene.json
status=0
build/apps/terrain_viewer/terrain_viewer "$scene" || status=$?
if [ "$status" -eq 3 ]; then
  echo "Rendering headless instead:"
  build/apps/overlay_render --scene "$scene" --width 1280 --height 800 --msaa 4 --out out/olinda
  exit 0
fi
exit "$status"
