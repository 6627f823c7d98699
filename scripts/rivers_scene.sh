#!/usr/bin/env bash
# Writes the world-scale lines scene of issue 41 into OUTDIR from Debian packages only, without
# the network: the globe scene of scripts/globe_scene.sh (its DEM and countries), plus every river
# of GSHHG's full-resolution set (gmt coast -Rd -Df -Ia -M: all river classes, about 44,000 lines
# and 2.6 M points) as rivers.gpkg, and three scene files beside scene.json:
#   rivers_px.json   the rivers 1.5 pixels wide (width_px)
#   rivers_m.json    the rivers 800 m wide (width_m)
#   terrain.json     no layers: the terrain's own time and memory
# Then e.g.: overlay_render --scene OUTDIR/rivers_m.json --width 1024 --height 768 --out OUT
# (docs/globe.md, "Lines", has what it measured). Re-running overwrites the files.
#
# Usage: scripts/rivers_scene.sh OUTDIR
# Needs: what globe_scene.sh needs, and gmt-gshhg-full (scripts/install-deps.sh has them).
set -euo pipefail

if [[ $# -ne 1 || "$1" == -* ]]; then
  sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//' >&2
  [[ "${1:-}" == -h || "${1:-}" == --help ]] && exit 0
  exit 2
fi
out=$1
here=$(cd "$(dirname "$0")" && pwd)
"$here/globe_scene.sh" "$out"

# GMT writes each river as a segment after a '>' header; a segment of one point is left out (GMT
# cuts rivers at its bins, and some pieces keep a single point; pieces of one point given twice
# are named by the loader and left out). Lon/lat on WGS 84.
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
(cd "$tmp" && gmt coast -Rd -Df -Ia -M) |  # in a temporary folder: GMT leaves gmt.history there
  awk 'function flush() { if (n > 1) print "{\"type\":\"Feature\",\"properties\":{},\"geometry\":" \
                                      "{\"type\":\"LineString\",\"coordinates\":[" s "]}}"; s = ""; n = 0 }
       /^>/ { flush(); next }
       { s = s (n ? "," : "") "[" $1 "," $2 "]"; n++ }
       END { flush() }' > "$out/rivers.geojsonl"
rm -f "$out/rivers.gpkg"
ogr2ogr -f GPKG "$out/rivers.gpkg" "$out/rivers.geojsonl" -a_srs EPSG:4326 -nln rivers
rm -f "$out/rivers.geojsonl"

# The scene files: scene.json's terrain and camera, with the rivers (or nothing) as the layers.
write_scene() {  # FILE LAYERS-JSON
  awk -v layers="$2" '
    /"layers": \[/ { print "  \"layers\": [" layers "]"; skip = 1; next }
    skip && /^  \]/ { skip = 0; next }
    !skip { print }' "$out/scene.json" > "$1"
}
write_scene "$out/rivers_px.json" \
  '{"name": "rivers", "kind": "line", "source": "rivers.gpkg", "style": {"color": "#1f5fff", "width_px": 1.5}}'
write_scene "$out/rivers_m.json" \
  '{"name": "rivers", "kind": "line", "source": "rivers.gpkg", "style": {"color": "#1f5fff", "width_m": 800}}'
write_scene "$out/terrain.json" ''
lines=$(ogrinfo -so "$out/rivers.gpkg" rivers | sed -n 's/^Feature Count: //p')
echo "rivers_scene.sh: $lines rivers in $out/rivers.gpkg; scenes rivers_px.json, rivers_m.json, terrain.json"
