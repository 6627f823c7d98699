#!/usr/bin/env bash
# Writes a national-border scene into OUTDIR from Debian packages only: the Digital Chart of the
# World country polygons of gmt-dcw, read with GMT (gmt coast -E... -M), one feature per country
# (all its parts united) in lon/lat as borders.gpkg; a synthetic DEM over the countries' box in
# UTM zone 33N as dem.tif (terrain_synth, SIZE² posts); and the scene file borders.json (the DEM,
# one polygon layer with 50 m outlines). Prints the countries', parts' and vertices' counts.
# With --coast it also writes coast.gpkg, the land of the countries' lon/lat box from the
# full-resolution GSHHG shorelines (gmt-gshhg-full), one polygon per part with lakes as holes,
# and coast.json (the same DEM with that layer instead). Re-running overwrites the files.
# docs/border-scene.md says what it makes and measured.
#
# Usage: scripts/border_scene.sh OUTDIR [--coast]
# Environment:
#   COUNTRIES=LIST      ISO 3166 codes for gmt coast -E (default NO,SE,FI,DK,EE,LV,LT)
#   SIZE=N              DEM posts a side (default 4097); the spacing follows, so that the square
#                       covers the countries' box in EPSG:32633 with 1 % to spare on each side
#   COAST_LAKES=0       with --coast: fill the lakes in (GSHHG level 1 only) [default 1: holes]
#   TERRAIN_SYNTH=PATH  the generator (default: BUILD_DIR/samples/synth/terrain_synth)
#   BUILD_DIR=DIR       the build directory to find it in (default: build/ of this repository)
# Needs: gmt and gmt-dcw (and gmt-gshhg-full for --coast), gdal-bin (ogr2ogr, ogrinfo), awk
# (scripts/install-deps.sh has them).
# Then: overlay_render --scene OUTDIR/borders.json (or coast.json) --out DIR
set -euo pipefail

usage() { sed -n '2,22p' "$0" | sed 's/^# \{0,1\}//'; }
coast=0
args=()
for arg in "$@"; do
  case $arg in
    -h | --help) usage; exit 0 ;;
    --coast) coast=1 ;;
    -*) echo "border_scene.sh: unknown option '$arg'" >&2; usage >&2; exit 2 ;;
    *) args+=("$arg") ;;
  esac
done
if [[ ${#args[@]} -ne 1 ]]; then
  usage >&2
  exit 2
fi
out=${args[0]}
codes=${COUNTRIES:-NO,SE,FI,DK,EE,LV,LT}
if ! [[ "$codes" =~ ^[A-Za-z]{2}(,[A-Za-z]{2})*$ ]]; then
  echo "border_scene.sh: COUNTRIES '$codes' is not a comma-separated list of 2-letter codes" >&2
  exit 2
fi
size=${SIZE:-4097}
if ! [[ "$size" =~ ^[0-9]+$ ]] || ((size < 33)); then
  echo "border_scene.sh: SIZE '$size' is not a DEM size (33 or more posts)" >&2
  exit 2
fi
lakes=${COAST_LAKES:-1}
if [[ "$lakes" != 0 && "$lakes" != 1 ]]; then
  echo "border_scene.sh: COAST_LAKES '$lakes' is not 0 or 1" >&2
  exit 2
fi

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
synth=${TERRAIN_SYNTH:-${BUILD_DIR:-$repo/build}/samples/synth/terrain_synth}
missing=()
for tool in gmt ogr2ogr ogrinfo awk; do
  command -v "$tool" >/dev/null 2>&1 || missing+=("$tool")
done
if [[ ${#missing[@]} -gt 0 ]]; then
  echo "border_scene.sh: missing ${missing[*]} (install the Debian packages gmt gmt-dcw gmt-gshhg-full gdal-bin:" \
    "scripts/install-deps.sh)" >&2
  exit 1
fi
if [[ ! -x "$synth" ]]; then
  echo "border_scene.sh: no terrain_synth at $synth (build it: ninja terrain_synth; or set TERRAIN_SYNTH" \
    "or BUILD_DIR)" >&2
  exit 1
fi

mkdir -p "$out"
out=$(cd "$out" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# 1. The DCW polygons as GMT multi-segment text: a header "> -ZNO Norway Segment 0" per part,
# then "lon<TAB>lat" rows, each ring closed. GMT runs in the temporary folder: it leaves a
# gmt.history file in its working directory.
(cd "$tmp" && gmt coast -E"$codes"+z -M >dcw.txt 2>gmt.err) || {
  cat "$tmp/gmt.err" >&2
  echo "border_scene.sh: gmt coast failed (is gmt-dcw installed? gmt get DIR_DCW)" >&2
  exit 1
}
for code in ${codes//,/ }; do
  code=${code^^}
  if ! grep -q "^> *-Z$code " "$tmp/dcw.txt"; then
    cat "$tmp/gmt.err" >&2
    echo "border_scene.sh: gmt coast gave no polygon for '$code' (gmt-dcw installed? gmt coast -E+l lists" \
      "the codes)" >&2
    exit 1
  fi
done

# 2. One WKT polygon per part, as CSV (code, name, part, WKT).
awk '
  function flush() {
    if (n >= 4) printf "%s,\"%s\",%d,\"POLYGON((%s))\"\n", code, name, part, pts
    else if (n > 0) dropped++
    n = 0; pts = ""
  }
  BEGIN { print "code,name,part,WKT" }
  /^>/ {
    flush()
    code = substr($2, 3); name = ""
    for (i = 3; i <= NF - 2; i++) name = name (i > 3 ? " " : "") $i
    gsub(/"/, "", name)
    part = $NF
    next
  }
  /^#/ { next }
  NF >= 2 { pts = pts (n ? "," : "") $1 " " $2; n++ }
  END {
    flush()
    if (dropped) printf "border_scene.sh: %d parts of fewer than 3 points left out\n", dropped > "/dev/stderr"
  }
' "$tmp/dcw.txt" >"$tmp/parts.csv"
ogr2ogr -f GPKG "$tmp/parts.gpkg" "$tmp/parts.csv" -oo GEOM_POSSIBLE_NAMES=WKT -oo KEEP_GEOM_COLUMNS=NO \
  -a_srs EPSG:4326 -nln parts -nlt POLYGON

# 3. One multipolygon per country: the union of its parts. GMT fills every part on its own, so
# the union is the area GMT draws; it also drops the parts DCW repeats (a lagoon of Denmark
# and a patch of Norway come twice) and the parts inside another, which the overlay's
# even-odd rule would otherwise cut out as holes, and joins parts that share an edge.
rm -f "$out/borders.gpkg"
ogr2ogr -f GPKG "$out/borders.gpkg" "$tmp/parts.gpkg" -dialect SQLite \
  -sql "SELECT code, name, ST_Multi(ST_Union(geom)) AS geom FROM parts GROUP BY code, name ORDER BY min(fid)" \
  -nln borders -nlt MULTIPOLYGON -a_srs EPSG:4326

# Counts: parts are the polygons (islands included); vertices are the distinct ones (each
# ring's closing point, a repeat of its first, not counted).
ogr2ogr -f CSV "$tmp/counts.csv" "$out/borders.gpkg" -dialect SQLite \
  -sql "SELECT code, name, ST_NumGeometries(geom) AS parts, ST_NRings(geom) AS rings,
        ST_NPoints(geom) - ST_NRings(geom) AS vertices, ST_IsValid(geom) AS valid FROM borders"
awk -F, 'NR == 1 { next }
  { gsub(/"/, ""); n++; p += $3; r += $4; v += $5; if ($6 != 1) bad++
    printf "border_scene.sh: %s %-10s %6d parts %7d vertices%s\n", $1, $2, $3, $5, ($4 > $3 ? " (with holes)" : "") }
  END { printf "border_scene.sh: %d countries, %d parts, %d rings, %d vertices\n", n, p, r, v
        if (bad) printf "border_scene.sh: %d features are not valid (OGC)\n", bad }' "$tmp/counts.csv"
ncountries=$(($(wc -l <"$tmp/counts.csv") - 1))
if ((ncountries != $(tr ',' '\n' <<<"$codes" | wc -l))); then
  echo "border_scene.sh: borders.gpkg has $ncountries countries, not one per code of $codes" \
    "(does ogr2ogr's SQLite dialect have SpatiaLite?)" >&2
  exit 1
fi

# 4. The DEM: a square in EPSG:32633 over the countries' projected box, 1 % to spare a side.
ogr2ogr -f GPKG "$tmp/utm.gpkg" "$out/borders.gpkg" -t_srs EPSG:32633 -nln borders
extent=$(ogrinfo -so "$tmp/utm.gpkg" borders | sed -n 's/^Extent: (\(.*\), \(.*\)) - (\(.*\), \(.*\))$/\1 \2 \3 \4/p')
if [[ -z "$extent" ]]; then
  echo "border_scene.sh: could not read the extent of the projected borders" >&2
  exit 1
fi
read -r spacing ox oy < <(awk -v n="$size" -v e="$extent" 'BEGIN {
  split(e, b, " "); w = b[3] - b[1]; h = b[4] - b[2]; side = (w > h ? w : h) * 1.02
  s = side / (n - 1); s = (s == int(s)) ? s : int(s) + 1          # whole metres, rounded up
  half = s * (n - 1) / 2; cx = (b[1] + b[3]) / 2; cy = (b[2] + b[4]) / 2
  printf "%d %.0f %.0f\n", s, cx - half, cy + half }')
echo "border_scene.sh: borders in EPSG:32633 span $extent; DEM ${size}² posts at $spacing m from ($ox, $oy)"
"$synth" --out "$out/dem.tif" --size "$size" --spacing "$spacing" --crs EPSG:32633 --origin "$ox,$oy" \
  --seed 7 --relief 1500 --no-holes

# 5. The scene file.
# write_scene FILE TITLE LAYER: a scene of dem.tif and one polygon layer LAYER (LAYER.gpkg).
write_scene() {
  cat >"$1" <<EOF
{
  "name": "$2",
  "terrain": {
    "dem": "dem.tif",
    "band": 1,
    "vertical_exaggeration": 1.0
  },
  "layers": [
    {
      "name": "$3",
      "kind": "polygon",
      "source": "$3.gpkg",
      "layer": "$3",
      "style": {
        "color": "#4e79a7",
        "opacity": 0.35,
        "outline_width_m": 50,
        "outline_color": "#1b2a49"
      }
    }
  ]
}
EOF
}
write_scene "$out/borders.json" "National borders of ${codes^^} (Digital Chart of the World, gmt-dcw)" borders
echo "border_scene.sh: wrote $out/borders.gpkg, $out/dem.tif, $out/borders.json"
[[ $coast == 1 ]] || exit 0

# 6. The coast layer: the land of the countries' lon/lat box (rounded out to 1e-6°) from the
# full-resolution GSHHG shorelines. gmt coast -W -M writes the shorelines of each 1° bin of
# GSHHG's binned file as its own piece ("> Shore Bin # 6503, Level 1"), cut at the bin's edges
# and clipped to -R; every piece has land on its left (level 1 land, 2 lake, 3 island in a lake,
# 4 pond in that island). There is no polygon dump (-G only paints), so the awk step below puts
# the polygons together again.
box=$(ogr2ogr -f CSV /vsistdout/ "$out/borders.gpkg" -dialect SQLite -sql \
  "SELECT min(ST_MinX(geom)), max(ST_MaxX(geom)), min(ST_MinY(geom)), max(ST_MaxY(geom)) FROM borders" |
  awk -F, 'function floor(v) { return int(v) - (v < int(v)) }
    NR == 2 { gsub(/"/, ""); f = 1e6
    printf "%.6f/%.6f/%.6f/%.6f", floor($1 * f) / f, -floor(-$2 * f) / f, floor($3 * f) / f, -floor(-$4 * f) / f }')
if [[ -z "$box" ]]; then
  echo "border_scene.sh: could not read the lon/lat box of borders.gpkg" >&2
  exit 1
fi
levels=()
[[ $lakes == 0 ]] && levels=(-A0/1/1)
(cd "$tmp" && gmt coast -Df -R"$box" "${levels[@]}" -W -M >shore.txt 2>gmt.err) || {
  cat "$tmp/gmt.err" >&2
  echo "border_scene.sh: gmt coast -Df failed (is gmt-gshhg-full installed? gmt get DIR_GSHHG)" >&2
  exit 1
}
echo "border_scene.sh: GSHHG full-resolution shorelines over -R$box:" \
  "$(grep -c '^>' "$tmp/shore.txt") pieces, $(grep -vc '^[>#]' "$tmp/shore.txt") points"

# 7. Pieces to rings, as CSV (ring, level, kind, WKT). Pieces that end where another starts are
# joined (the bins' shared edges give the same point to both). A ring is a shell if it turns
# counter-clockwise (land inside) and a hole if clockwise (a lake or pond). Where the box cuts
# land, GMT leaves either open runs that end on the box or rings it closed along the box; both
# become chains from box to box, and each is closed by walking the box's boundary
# counter-clockwise (the land's side) from its end to the nearest chain start, corners included,
# until the walk is back at the first chain. A lake cut by the box so becomes a bay of the land
# around it.
awk -v R="$box" '
  function abs(v) { return v < 0 ? -v : v }
  function side(x, y) {  # the sides of the box the point is on, as digits: 1 S, 2 E, 3 N, 4 W
    return (abs(y - S) < eps ? "1" : "") (abs(x - E) < eps ? "2" : "") (abs(y - N) < eps ? "3" : "") \
      (abs(x - W) < eps ? "4" : "")
  }
  function along(i, j,    a, b, d) {  # does the segment from point i to point j run along a side?
    a = side(px[i], py[i]); b = side(px[j], py[j])
    for (d = 1; d <= 4; d++) if (index(a, d) && index(b, d)) return 1
    return 0
  }
  function perim(x, y) {  # where the point is on the box boundary, counter-clockwise from (W, S)
    if (abs(y - S) < eps && x < E - eps) return (x - W) / (E - W)
    if (abs(x - E) < eps && y < N - eps) return 1 + (y - S) / (N - S)
    if (abs(y - N) < eps && x > W + eps) return 2 + (E - x) / (E - W)
    return 3 + (N - y) / (N - S)
  }
  function load(txt,    k, i, c, nn) {  # "x y,x y,..." into px[], py[]; returns the count
    nn = split(txt, k, ",")
    for (i = 1; i <= nn; i++) { split(k[i], c, " "); px[i] = c[1]; py[i] = c[2] }
    return nn
  }
  function emit(level, txt,    nn, i, a) {
    nn = load(txt); a = 0
    if (nn < 4) { degenerate++; return }
    for (i = 1; i < nn; i++) a += px[i] * py[i + 1] - px[i + 1] * py[i]
    rings++
    printf "%d,%d,%s,\"POLYGON((%s))\"\n", rings, level, (a > 0 ? "shell" : "hole"), txt
  }
  function addchain(level, txt, sx, sy, ex, ey) {
    nc++; ctxt[nc] = txt; clev[nc] = level; ts[nc] = perim(sx, sy); te[nc] = perim(ex, ey)
    if (side(sx, sy) == "" || side(ex, ey) == "") offbox++
  }
  function ring(level, txt,    nn, i, k, s, t, cur, cn, sx, sy) {
    nn = load(txt); s = 0
    for (i = 1; i < nn; i++) if (along(i, i + 1)) { s = i + 1; break }
    if (!s) { emit(level, txt); return }
    cur = ""; cn = 0
    for (k = 0; k < nn - 1; k++) {  # from point s round the ring, cut at each run along the box
      i = (s - 1 + k) % (nn - 1) + 1; t = i % (nn - 1) + 1
      if (!cn) { sx = px[i]; sy = py[i] }
      cur = cur (cn ? "," : "") px[i] " " py[i]; cn++
      if (along(i, t)) {
        if (cn >= 2) addchain(level, cur, sx, sy, px[i], py[i])
        cur = ""; cn = 0
      }
    }
    if (cn) addchain(level, cur "," px[s] " " py[s], sx, sy, px[s], py[s])
  }
  function follow(i,    j, txt, p) {  # joins pieces from piece i on, end to start
    j = i; txt = pts[i]; used[i] = 1
    while ((ek[j] in bystart) && !used[bystart[ek[j]]]) {
      j = bystart[ek[j]]; used[j] = 1; p = pts[j]; sub(/^[^,]*,/, "", p); txt = txt "," p
    }
    last = j
    return txt
  }
  function flush() {
    if (np >= 2) { m++; lev[m] = level; pts[m] = ptxt; sk[m] = fx " " fy; ek[m] = lx " " ly }
    else if (np == 1) single++
    np = 0; ptxt = ""
  }
  BEGIN { split(R, b, "/"); W = b[1]; E = b[2]; S = b[3]; N = b[4]; eps = 1e-9
    print "ring,level,kind,WKT" }
  /^>/ { flush(); level = $NF; next }
  /^#/ { next }
  NF >= 2 { if (!np) { fx = $1; fy = $2 } lx = $1; ly = $2; ptxt = ptxt (np ? "," : "") $1 " " $2; np++ }
  END {
    flush()
    for (i = 1; i <= m; i++) {
      if (sk[i] == ek[i]) { used[i] = 1; ring(lev[i], pts[i]); continue }
      if (sk[i] in bystart) twice++; else bystart[sk[i]] = i
      byend[ek[i]] = i
    }
    for (i = 1; i <= m; i++) {  # runs that start where no piece ends: from box to box
      if (used[i] || (sk[i] in byend)) continue
      txt = follow(i); split(sk[i], s0, " "); split(ek[last], e0, " ")
      addchain(lev[i], txt, s0[1], s0[2], e0[1], e0[2])
    }
    for (i = 1; i <= m; i++) {  # the rest close on themselves
      if (used[i]) continue
      txt = follow(i)
      if (ek[last] == sk[i]) ring(lev[i], txt); else unclosed++
    }
    cx[0] = W; cy[0] = S; cx[1] = E; cy[1] = S; cx[2] = E; cy[2] = N; cx[3] = W; cy[3] = N
    for (c = 1; c <= nc; c++) {
      if (done[c]) continue
      txt = ""; k = c; level = clev[c]
      while (!done[k]) {
        done[k] = 1; txt = txt (txt == "" ? "" : ",") ctxt[k]; if (clev[k] < level) level = clev[k]
        best = 0; bd = 5
        for (q = 1; q <= nc; q++) { d = ts[q] - te[k]; if (d < 0) d += 4; if (d < bd) { bd = d; best = q } }
        for (corner = int(te[k]) + 1; corner <= te[k] + bd; corner++)
          txt = txt "," cx[corner % 4] " " cy[corner % 4]
        k = best
      }
      if (k != c) badwalk++
      split(ctxt[c], p0, ","); emit(level, txt "," p0[1]); closed++
    }
    printf "border_scene.sh: %d pieces joined into %d rings, %d of them closed along the box from %d chains\n",
      m, rings, closed, nc > "/dev/stderr"
    if (twice + unclosed + offbox + badwalk + degenerate)
      printf "border_scene.sh: pieces left out or suspect: %d starts shared, %d runs not closed, %d chains not ending on the box, %d box walks not closed, %d rings of fewer than 3 points\n",
        twice, unclosed, offbox, badwalk, degenerate > "/dev/stderr"
    if (twice + unclosed + offbox + badwalk) exit 1
  }
' "$tmp/shore.txt" >"$tmp/rings.csv"
ogr2ogr -f GPKG "$tmp/rings.gpkg" "$tmp/rings.csv" -oo GEOM_POSSIBLE_NAMES=WKT -oo KEEP_GEOM_COLUMNS=NO \
  -oo AUTODETECT_TYPE=YES -a_srs EPSG:4326 -nln rings -nlt POLYGON

# 8. Each hole goes into the smallest shell that holds its first point (a point on the lake's
# shore, so inside the land around the lake and outside any island in it). The GeoPackage's
# R-tree narrows the shells down; SQL on a GeoPackage runs in SQLite with SpatiaLite's functions.
ogrinfo -q "$tmp/rings.gpkg" -sql "CREATE TABLE parent AS SELECT h.fid AS hole, (SELECT s.fid FROM rings s
  JOIN rtree_rings_geom r ON r.id = s.fid WHERE s.kind = 'shell' AND r.minx <= X(h.pt) AND r.maxx >= X(h.pt)
  AND r.miny <= Y(h.pt) AND r.maxy >= Y(h.pt) AND ST_Contains(s.geom, h.pt) ORDER BY ST_Area(s.geom) LIMIT 1)
  AS shell FROM (SELECT fid, ST_StartPoint(ST_ExteriorRing(geom)) AS pt FROM rings WHERE kind = 'hole') h" >/dev/null
ogr2ogr -f GPKG -update "$tmp/rings.gpkg" "$tmp/rings.gpkg" -nln parts -nlt POLYGON -sql \
  "SELECT s.fid AS ring, s.level AS level, CASE WHEN hs.rings IS NULL THEN s.geom
     ELSE MakePolygon(ST_ExteriorRing(s.geom), hs.rings) END AS geom
   FROM rings s LEFT JOIN (SELECT p.shell AS shell, ST_Collect(ST_ExteriorRing(r.geom)) AS rings
     FROM parent p JOIN rings r ON r.fid = p.hole GROUP BY p.shell) hs ON hs.shell = s.fid
   WHERE s.kind = 'shell' ORDER BY s.fid"
read -r orphans invalid < <(ogr2ogr -f CSV /vsistdout/ "$tmp/rings.gpkg" -sql \
  "SELECT (SELECT count(*) FROM parent WHERE shell IS NULL), (SELECT count(*) FROM parts WHERE NOT ST_IsValid(geom))" \
  2>/dev/null | awk -F, 'NR == 2 { gsub(/"/, ""); print $1, $2 }')
if ((${orphans:-0} > 0)); then
  echo "border_scene.sh: $orphans lakes found no land around them and are left out" >&2
fi

# 9. coast.gpkg: one polygon per part, attribute level (1 land, 3 an island in a lake). A part
# that is not valid is mended with SpatiaLite's MakeValid: where the box's edge meets a lake's
# shore, the walk above makes a ring that touches itself in a point, which OGC does not allow.
rm -f "$out/coast.gpkg"
ogr2ogr -f GPKG "$out/coast.gpkg" "$tmp/rings.gpkg" -nln coast -nlt POLYGON -explodecollections -sql \
  "SELECT level, CASE WHEN ST_IsValid(geom) THEN geom ELSE MakeValid(geom) END AS geom FROM parts ORDER BY ring" \
  2>"$tmp/valid.err" || { cat "$tmp/valid.err" >&2; exit 1; }
ogr2ogr -f CSV "$tmp/coast.csv" "$out/coast.gpkg" -dialect SQLite -sql \
  "SELECT count(*), sum(ST_NRings(geom)), sum(ST_NPoints(geom) - ST_NRings(geom)), sum(ST_IsValid(geom)),
     sum(level = 3), max(ST_NPoints(geom) - ST_NRings(geom)) FROM coast"
awk -F, -v invalid="${invalid:-?}" 'NR == 2 { gsub(/"/, "")
  printf "border_scene.sh: coast: %d parts (%d of them islands in lakes), %d holes, %d vertices" \
    " (the largest part %d); %s parts mended with MakeValid\n", $1, $5, $2 - $1, $3, $6, invalid
  if ($4 != $1) { printf "border_scene.sh: %d parts of coast.gpkg are not valid (OGC)\n", $1 - $4 > "/dev/stderr"
    exit 1 } }' "$tmp/coast.csv"

write_scene "$out/coast.json" "Land of the ${codes^^} box $box (GSHHG full resolution, gmt-gshhg-full)" coast
echo "border_scene.sh: wrote $out/coast.gpkg, $out/coast.json"
