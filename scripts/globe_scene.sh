#!/usr/bin/env bash
# Writes a globe scene into OUTDIR from Debian packages only, without the network: the Digital
# Chart of the World country polygons of gmt-dcw, read with GMT (gmt coast -E... -M), one
# (multi)polygon feature per country in lon/lat as countries.gpkg; a global DEM in lon/lat as
# dem.tif, heights in metres above the WGS 84 ellipsoid (real GSHHG coastlines, a made-up relief
# on land and sea floor, plus the EGM96 geoid undulation of proj-data); and the scene file
# scene.json. Prints the features', parts' and vertices' counts and the DEM's size and range.
# Re-running overwrites the files. docs/globe-scene.md says what it makes and measured.
#
# Usage: scripts/globe_scene.sh OUTDIR
# Environment:
#   COUNTRIES=LIST   codes for gmt coast -E: ISO 3166 country codes (RU) or DCW continents
#                    (=SA) (default =SA,AQ,RU,FJ: South America, Antarctica, Russia, Fiji)
#   POLE=close|keep  a ring that goes round a pole (Antarctica): close it along the antimeridian
#                    and the pole (default close), or keep it as GMT writes it (0-360° with a
#                    360° jump; not a valid planar polygon, so not united with other parts)
#   RES=DEG          the DEM's cell size in degrees; 180/RES must be a whole number (default
#                    0.25: 1440 x 720 cells)
#   GSHHG=c|l|i|h|f  the GSHHG resolution of the land/sea mask (default l for RES >= 0.2, else
#                    i; both are in gmt-gshhg-low; h needs gmt-gshhg-high, f gmt-gshhg-full)
# Needs: gmt, gmt-dcw, gmt-gshhg-low, gdal-bin (ogr2ogr, ogrinfo, gdal_translate, gdalwarp,
# gdalinfo, gdallocationinfo), proj-data, awk (scripts/install-deps.sh has them).
set -euo pipefail

usage() { sed -n '2,22p' "$0" | sed 's/^# \{0,1\}//'; }
args=()
for arg in "$@"; do
  case $arg in
    -h | --help) usage; exit 0 ;;
    -*) echo "globe_scene.sh: unknown option '$arg'" >&2; usage >&2; exit 2 ;;
    *) args+=("$arg") ;;
  esac
done
if [[ ${#args[@]} -ne 1 ]]; then
  usage >&2
  exit 2
fi
out=${args[0]}
codes=${COUNTRIES:-=SA,AQ,RU,FJ}
if ! [[ "$codes" =~ ^=?[A-Za-z]{2}(,=?[A-Za-z]{2})*$ ]]; then
  echo "globe_scene.sh: COUNTRIES '$codes' is not a comma-separated list of 2-letter codes" \
    "(=XX for a DCW continent)" >&2
  exit 2
fi
codes=${codes^^}
pole=${POLE:-close}
if [[ "$pole" != close && "$pole" != keep ]]; then
  echo "globe_scene.sh: POLE '$pole' is not close or keep" >&2
  exit 2
fi
res=${RES:-0.25}
if ! [[ "$res" =~ ^[0-9]*\.?[0-9]+$ ]] ||
  ! read -r ncols nrows < <(awk -v r="$res" 'BEGIN { if (r <= 0 || r > 10) exit 1
      n = 180 / r; if (n - int(n + 0.5) > 1e-9 || int(n + 0.5) - n > 1e-9) exit 1
      printf "%d %d\n", 2 * int(n + 0.5), int(n + 0.5) }'); then
  echo "globe_scene.sh: RES '$res' is not a cell size in degrees that divides 180 (0.25, 0.1, 0.5, 1 ...)" >&2
  exit 2
fi
gshhg=${GSHHG:-$(awk -v r="$res" 'BEGIN { print (r >= 0.2 ? "l" : "i") }')}
if ! [[ "$gshhg" =~ ^[clihf]$ ]]; then
  echo "globe_scene.sh: GSHHG '$gshhg' is not one of c l i h f" >&2
  exit 2
fi
# The EGM96 grid PROJ uses for EPSG:5773 (proj.db names it us_nga_egm96_15.tif, with this file
# of proj-data as its alternative); read here for the checks.
geoid=/usr/share/proj/egm96_15.gtx

missing=()
for tool in gmt ogr2ogr ogrinfo gdal_translate gdalwarp gdalinfo gdallocationinfo awk; do
  command -v "$tool" >/dev/null 2>&1 || missing+=("$tool")
done
if [[ ${#missing[@]} -gt 0 ]]; then
  echo "globe_scene.sh: missing ${missing[*]} (install the Debian packages gmt gmt-dcw gmt-gshhg-low" \
    "gdal-bin proj-data: scripts/install-deps.sh)" >&2
  exit 1
fi
if [[ ! -r "$geoid" ]]; then
  echo "globe_scene.sh: no EGM96 geoid grid at $geoid (install the Debian package proj-data)" >&2
  exit 1
fi
# PROJ must not fetch grids from the CDN: the geoid comes from proj-data or nowhere. (Without
# the grid, PROJ falls back on a null shift without a word: the check after step 5 catches it.)
export PROJ_NETWORK=OFF

mkdir -p "$out"
out=$(cd "$out" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
rm -f "$out/countries.gpkg" "$out/dem.tif" "$out/scene.json"
start=$SECONDS

# 1. The DCW polygons as GMT multi-segment text: a header "> -ZRU Russian Federation Segment 0"
# per part, then "lon<TAB>lat" rows, each ring closed (last row = first row). GMT runs in the
# temporary folder: it leaves a gmt.history file in its working directory. Each ring comes out
# continuous (no step of 180° or more between neighbours; Wrangel Island runs 178.6-182.5),
# but the longitudes' base depends on the whole set asked for (Brazil alone comes out in
# 286-325, with Russia in -74 to -35), and a ring round a pole (Antarctica) runs 0-360 with a
# 360° jump back on its closing edge.
(cd "$tmp" && gmt coast -E"$codes"+z -M >dcw.txt 2>gmt.err) || {
  cat "$tmp/gmt.err" >&2
  echo "globe_scene.sh: gmt coast failed (is gmt-dcw installed? gmt get DIR_DCW)" >&2
  exit 1
}
for code in ${codes//,/ }; do
  [[ $code == =* ]] && pat="-Z[A-Z][A-Z]" || pat="-Z$code"
  if ! grep -q "^> *$pat " "$tmp/dcw.txt"; then
    cat "$tmp/gmt.err" >&2
    echo "globe_scene.sh: gmt coast gave no polygon for '$code' (gmt-dcw installed? gmt coast -E+l lists" \
      "the codes)" >&2
    exit 1
  fi
done

# 2. One WKT polygon per part, as CSV (code, name, part, pole, WKT). A row that repeats the
# one before is left out (DCW's 16-bit coordinates repeat many: 395,581 of Argentina's 639,494
# rows). Longitudes are normalised:
# - a ring that does not go round a pole is shifted as a whole by a multiple of 360° so that
#   its westernmost point is in [-180, 180); it is never split, so a ring across the
#   antimeridian runs past +180 (never below -180);
# - a ring that goes round a pole (its longitude steps, each taken the short way round, add up
#   to ±360°) is, with POLE=close, cut where it crosses the antimeridian (exactly once, or the
#   script stops) and closed along it and the pole: the crossing point on +180 and on -180
#   (latitude interpolated linearly in lon/lat), then (±180, ±90): the pole (-90 if the ring's
#   mean latitude is south) as an edge along the pole's latitude. All longitudes in [-180, 180].
#   With POLE=keep it is written as GMT wrote it.
awk -v pole_mode="$pole" '
  function floor(v) { return int(v) - (v < int(v)) }
  function lon(v) { return sprintf("%.12g", v) }   # awk would print 6 digits
  function head(p) { printf "%s,\"%s\",%d,%d,\"POLYGON((", code, name, part, p }
  function flush(   i, j, w, d, mn, jumps, at, a, b, la, lb, t, latc, P, sy, s, k, first) {
    if (n == 0) return
    if (n < 4) { dropped++; n = 0; return }
    w = 0; mn = x[1]; sy = 0; jumps = 0
    for (i = 1; i < n; i++) {
      d = x[i + 1] - x[i]
      if (d > 180 || d < -180) jumps++
      w += d - 360 * int((d + (d > 0 ? 180 : -180)) / 360)
      if (x[i] < mn) mn = x[i]
      sy += y[i]
    }
    if (w > -180 && w < 180) {                    # an ordinary ring
      if (jumps) {
        printf "globe_scene.sh: %s part %d has a step of 180° or more but does not go round a pole\n", \
          code, part > "/dev/stderr"; bad = 1
      }
      s = -360 * floor((mn + 180) / 360)
      head(0)
      for (i = 1; i <= n; i++) printf "%s%s %s", (i > 1 ? "," : ""), (s ? lon(x[i] + s) : xs[i]), ys[i]
      print "))\""
    } else if (pole_mode == "keep") {             # round a pole, kept as GMT wrote it
      head(1)
      for (i = 1; i <= n; i++) printf "%s%s %s", (i > 1 ? "," : ""), xs[i], ys[i]
      print "))\""
      npole++
    } else {                                      # round a pole, closed along it
      m = n - 1                                   # the ring without its closing row
      for (i = 1; i <= m; i++) u[i] = x[i] - 360 * floor((x[i] + 180) / 360)
      jumps = 0
      for (i = 1; i <= m; i++) {
        j = i % m + 1; d = u[j] - u[i]
        if (d > 180 || d < -180) { jumps++; at = i }
      }
      if (jumps != 1) {
        printf "globe_scene.sh: %s part %d goes round a pole but crosses the antimeridian %d times;" \
          " POLE=keep writes it as GMT does\n", code, part, jumps > "/dev/stderr"
        bad = 1; n = 0; return
      }
      j = at % m + 1; a = u[at]; b = u[j]; la = y[at]; lb = y[j]
      if (a < b) { e1 = -180; e2 = 180 } else { e1 = 180; e2 = -180 }   # a is on the e1 side
      t = (e1 - a) / ((b - (b - a > 0 ? 360 : -360)) - a)
      latc = sprintf("%.12g", la + t * (lb - la))
      P = (sy / m < 0) ? -90 : 90
      first = e2 " " latc
      head(0)
      printf "%s", first
      for (k = 0; k < m; k++) { i = (j - 1 + k) % m + 1; printf ",%s %s", (u[i] == x[i] ? xs[i] : lon(u[i])), ys[i] }
      print "," e1 " " latc "," e1 " " P "," e2 " " P "," first "))\""
      npole++
      printf "globe_scene.sh: %s part %d goes round the pole at %d°: cut at the antimeridian at latitude" \
        " %s, closed along it and the pole\n", code, part, P, latc > "/dev/stderr"
    }
    n = 0
  }
  BEGIN { print "code,name,part,pole,WKT" }
  /^>/ {
    flush()
    code = substr($2, 3); name = ""
    for (i = 3; i <= NF - 2; i++) name = name (i > 3 ? " " : "") $i
    gsub(/"/, "", name)
    part = $NF
    next
  }
  /^#/ { next }
  NF >= 2 {
    if (n && $1 == xs[n] && $2 == ys[n]) { repeats++; next }
    n++; xs[n] = $1; ys[n] = $2; x[n] = $1 + 0; y[n] = $2 + 0
  }
  END {
    flush()
    printf "globe_scene.sh: %d rows that repeat the row before left out\n", repeats > "/dev/stderr"
    if (dropped) printf "globe_scene.sh: %d parts of fewer than 3 points left out\n", dropped > "/dev/stderr"
    if (bad) exit 1
  }
' "$tmp/dcw.txt" >"$tmp/parts.csv"
# (a line of the CSV can be longer than the driver's default limit of 10^7 characters: the
# mainland of Argentina is one ring of 606,368 points)
echo 'String,String,Integer,Integer,WKT' >"$tmp/parts.csvt"   # the columns' types
ogr2ogr --config OGR_CSV_MAX_LINE_SIZE 0 -f GPKG "$tmp/parts.gpkg" "$tmp/parts.csv" -oo GEOM_POSSIBLE_NAMES=WKT \
  -oo KEEP_GEOM_COLUMNS=NO -lco GEOMETRY_NAME=geom -a_srs EPSG:4326 -nln parts -nlt POLYGON

# 3. One multipolygon per country: the union of its parts (as in border_scene.sh: DCW repeats a
# few parts and has parts inside others; GMT fills each part on its own).
# - A few DCW parts are not valid (OGC): a ring that touches or crosses itself. GEOS cannot
#   unite them, so they are listed here and repaired first with SpatiaLite's MakeValid (its
#   polygons only); the rest is left as it is.
# - A ring kept round a pole (POLE=keep) is not a valid planar polygon either: it is not
#   repaired nor united, only collected into its country's multipolygon.
# geos_quiet COMMAND...: runs it without GEOS's and RTTOPO's warnings, one for each part that
# is not valid, every time ST_IsValid looks at it (the errors still show).
geos_quiet() {
  local rc=0
  "$@" 2>"$tmp/geos.err" || rc=$?
  grep -v -e '^GEOS warning: ' -e '^RTTOPO warning: ' -e '^$' "$tmp/geos.err" >&2 || true
  return $rc
}
geos_quiet ogr2ogr -f CSV "$tmp/invalid.csv" "$tmp/parts.gpkg" -dialect SQLite -sql \
  "SELECT code, part, ST_NPoints(geom) AS points, ST_IsValidReason(geom) AS reason,
     ST_NumGeometries(CollectionExtract(MakeValid(geom), 3)) AS repaired_parts
   FROM parts WHERE pole = 0 AND NOT ST_IsValid(geom)"
awk -F, 'NR > 1 { gsub(/"/, ""); n++
    printf "globe_scene.sh: %s part %d (%d points) is not valid: %s; repaired into %d polygons\n", $1, $2, $3, $4, $5 }
  END { printf "globe_scene.sh: %d parts were not valid (repaired)\n", n + 0 }' "$tmp/invalid.csv"
part="CASE WHEN ST_IsValid(geom) THEN geom ELSE CollectionExtract(MakeValid(geom), 3) END"
geos_quiet ogr2ogr -f GPKG "$out/countries.gpkg" "$tmp/parts.gpkg" -dialect SQLite -sql \
  "SELECT code, name, ST_Multi(CASE
     WHEN max(pole) = 0 THEN ST_Union(CASE WHEN pole = 0 THEN $part END)
     WHEN min(pole) = 1 THEN ST_Collect(geom)
     ELSE ST_Collect(ST_Union(CASE WHEN pole = 0 THEN $part END), ST_Collect(CASE WHEN pole = 1 THEN geom END))
   END) AS geom FROM parts GROUP BY code, name ORDER BY min(fid)" \
  -nln countries -nlt MULTIPOLYGON -a_srs EPSG:4326

# Counts: parts are the polygons (islands included); vertices are the distinct ones (each
# ring's closing point, a repeat of its first, not counted).
geos_quiet ogr2ogr -f CSV "$tmp/counts.csv" "$out/countries.gpkg" -dialect SQLite \
  -sql "SELECT code, name, ST_NumGeometries(geom) AS parts, ST_NRings(geom) AS rings,
        ST_NPoints(geom) - ST_NRings(geom) AS vertices, ST_IsValid(geom) AS valid,
        ST_MinX(geom) AS w, ST_MaxX(geom) AS e, ST_MinY(geom) AS s, ST_MaxY(geom) AS n FROM countries"
awk -F, 'NR == 1 { next }
  { gsub(/"/, ""); n++; p += $3; r += $4; v += $5; if ($6 != 1) bad++
    printf "globe_scene.sh: %s %-28.28s %5d parts %7d vertices  lon %9.4f %9.4f  lat %8.4f %8.4f%s%s\n",
      $1, $2, $3, $5, $7, $8, $9, $10, ($4 > $3 ? " (holes)" : ""), ($6 != 1 ? " NOT VALID" : "") }
  END { printf "globe_scene.sh: %d features, %d parts, %d rings, %d vertices\n", n, p, r, v
        if (bad) printf "globe_scene.sh: %d features are not valid (OGC)\n", bad }' "$tmp/counts.csv"
nfeatures=$(($(wc -l <"$tmp/counts.csv") - 1))
ncodes=$(grep '^>' "$tmp/dcw.txt" | awk '{ print $2 }' | sort -u | wc -l)
if ((nfeatures != ncodes)); then
  echo "globe_scene.sh: countries.gpkg has $nfeatures features, not one per country of gmt coast's $ncodes" \
    "(does ogr2ogr's SQLite dialect have SpatiaLite?)" >&2
  exit 1
fi

# 4. The DEM, first as heights above the EGM96 geoid (like SRTM's), in GMT's netCDF grids, cells
# centred on the RES grid (pixel registration): -180..180 x -90..90.
R=(-R-180/180/-90/90 -r)
# Land (GSHHG levels 1-4: land, lakes, islands in lakes, ponds all count as land) 1, sea 0.
(cd "$tmp" && gmt grdlandmask "${R[@]}" -I"$res" -D"$gshhg" -N0/1/1/1/1 -Gmask.nc 2>gmt.err &&
  gmt grdlandmask "${R[@]}" -I1 -Dl -N0/1/1/1/1 -Gmask1.nc 2>>gmt.err) || {
  cat "$tmp/gmt.err" >&2
  echo "globe_scene.sh: gmt grdlandmask failed (is gmt-gshhg-low installed? gmt get DIR_GSHHG)" >&2
  exit 1
}
# How far inland or out to sea, as the 1° mask smoothed with Gaussians of 800 and 2,500 km
# (filter width, spherical distances) and resampled to RES: about 0.5 on the coast, towards 1
# deep inland and 0 far out at sea. A cheap stand-in for the distance to the coast.
(cd "$tmp" && gmt grdfilter mask1.nc -Fg800 -D4 -Gnear1.nc 2>gmt.err &&
  gmt grdfilter mask1.nc -Fg2500 -D4 -Gfar1.nc 2>>gmt.err &&
  gmt grdsample near1.nc "${R[@]}" -I"$res" -Gnear.nc 2>>gmt.err &&
  gmt grdsample far1.nc "${R[@]}" -I"$res" -Gfar.nc 2>>gmt.err) || {
  cat "$tmp/gmt.err" >&2
  echo "globe_scene.sh: gmt grdfilter or grdsample failed" >&2
  exit 1
}
# Ridges: 1 - |sin(k d·p + φ)| for the unit vector p of each cell and a few fixed directions d,
# wave numbers k and phases φ; a function of the point on the sphere, so it runs on seamlessly
# across the antimeridian and at the poles. No random numbers: every run gives the same grid.
# ridge K DX DY DZ PHI W: adds W (1 - |sin(K d·p + PHI)|) to the sum on grdmath's stack. The
# weights add up to 1, so the sum is in 0..1 (its mean is about 1 - 2/π).
ridges=()
ridge() {
  local first=$((${#ridges[@]} == 0))
  ridges+=(RCL@cx "$2" MUL RCL@cy "$3" MUL ADD RCL@cz "$4" MUL ADD "$1" MUL "$5" ADD SIN ABS 1 EXCH SUB
    "$6" MUL)
  ((first)) || ridges+=(ADD)
}
ridge 7 0.48 0.60 0.64 0.3 0.32
ridge 13 -0.70 0.10 0.71 1.1 0.24
ridge 23 0.15 -0.93 0.33 2.0 0.18
ridge 41 0.83 0.42 -0.37 0.7 0.12
ridge 67 -0.26 0.55 0.79 2.6 0.08
ridge 109 0.61 -0.71 0.35 1.9 0.06
# land: 2 m at the coast, up to ~900 m of plain and plateau, ridges up to ~4,000 m higher
# inland; sea: -20 m at the coast, down to ~ -5,200 m in the open ocean, ridges of up to 1,500 m
# there, and never above -5 m, so that the coast (height 0) stays the mask's.
# (the grid's region and cells are mask.nc's: grdmath takes no -R -I with grid files)
(cd "$tmp" && gmt grdmath \
  Y COSD X COSD MUL STO@cx POP Y COSD X SIND MUL STO@cy POP Y SIND STO@cz POP \
  "${ridges[@]}" STO@rg POP \
  near.nc 0.45 SUB 0.55 DIV 0 MAX 1 MIN STO@in POP \
  far.nc 0.4 SUB 0.6 DIV 0 MAX 1 MIN STO@ct POP \
  0.5 near.nc SUB 2 MUL 0 MAX 1 MIN STO@off POP \
  0.5 far.nc SUB 2 MUL 0 MAX 1 MIN 0.6 POW STO@open POP \
  2 RCL@in 150 MUL ADD RCL@ct 750 MUL ADD RCL@in 0.8 POW 3700 MUL 300 ADD RCL@rg 2 POW MUL ADD STO@land POP \
  -20 RCL@off 800 MUL SUB RCL@open 4400 MUL SUB RCL@open 1500 MUL RCL@rg 3 POW MUL ADD -5 MIN STO@sea POP \
  mask.nc RCL@land MUL 1 mask.nc SUB RCL@sea MUL ADD = ortho.nc 2>gmt.err) || {
  cat "$tmp/gmt.err" >&2
  echo "globe_scene.sh: gmt grdmath failed" >&2
  exit 1
}
gdal_translate -q -of GTiff -ot Float32 -a_srs EPSG:4326 "$tmp/ortho.nc" "$tmp/ortho.tif"

# 5. Heights above the ellipsoid: h = H + N, N the EGM96 undulation, by GDAL/PROJ's vertical
# transformation from EPSG:4326+5773 (WGS 84 + EGM96 height) to EPSG:4979 (WGS 84 3D), which
# uses the proj-data grid (egm96_15.gtx, 15' nodes, bilinear). The horizontal grid is kept as is
# (-te/-ts the same, nearest: every cell maps onto itself); then the 2D CRS EPSG:4326 is written,
# as asked, with the heights' datum in the band's metadata.
gdalwarp -q -overwrite -s_srs EPSG:4326+5773 -t_srs EPSG:4979 -te -180 -90 180 90 -ts "$ncols" "$nrows" \
  -r near -ot Float32 "$tmp/ortho.tif" "$tmp/ellipsoidal.tif"
gdal_translate -q -of GTiff -ot Float32 -a_srs EPSG:4326 -a_nodata none -co COMPRESS=DEFLATE -co PREDICTOR=3 -co TILED=YES \
  -mo "HEIGHTS=metres above the WGS 84 ellipsoid (EGM96 geoid heights + EGM96 undulation)" \
  -mo "SOURCE=scripts/globe_scene.sh: GSHHG ($gshhg) land/sea mask, synthetic relief, EGM96 (proj-data)" \
  "$tmp/ellipsoidal.tif" "$out/dem.tif"

# Checks: the applied shift h - H over the whole grid against the geoid grid resampled by GMT
# (grdsample, bilinear: GMT's own reading of the grid, not PROJ's), and at a few cells against
# the bilinear mean of the geoid's four nodes around the cell, read with gdallocationinfo.
(cd "$tmp" && gmt grdsample "$geoid=gd" "${R[@]}" -I"$res" -fg -nl -Gn.nc 2>gmt.err &&
  gdal_translate -q -of netCDF "$tmp/ellipsoidal.tif" "$tmp/ell.nc" &&
  gmt grdmath ell.nc ortho.nc SUB n.nc SUB ABS = dev.nc 2>>gmt.err) || {
  cat "$tmp/gmt.err" >&2
  echo "globe_scene.sh: could not check the geoid shift" >&2
  exit 1
}
maxdev=$(gmt grdinfo -C "$tmp/dev.nc" | cut -f7)
echo "globe_scene.sh: h - H against EGM96 (GMT grdsample of $geoid), all cells: max |difference|" \
  "$maxdev m"
# at the centres of the cells holding these points
printf '%s\n' "-74.1 40.7 NYC" "-78.1 -1.6 Andes" "147.1 -5.1 New_Guinea" "78.1 5.1 Indian_Ocean" \
  "179.9 65.1 Chukotka" "-179.9 -85.1 Antarctica" >"$tmp/points.txt"
while read -r lon lat label; do
  read -r lon lat < <(awk -v x="$lon" -v y="$lat" -v r="$res" 'BEGIN {
    printf "%.9f %.9f\n", -180 + (int((x + 180) / r) + 0.5) * r, -90 + (int((y + 90) / r) + 0.5) * r }')
  H=$(gdallocationinfo -valonly -geoloc "$tmp/ortho.tif" "$lon" "$lat")
  h=$(gdallocationinfo -valonly -geoloc "$out/dem.tif" "$lon" "$lat")
  # the geoid's nodes are every 0.25° from -180 (lon) and -90 (lat); 180 is -180
  read -r x0 x1 y0 y1 fx fy < <(awk -v x="$lon" -v y="$lat" 'BEGIN {
    i = int((x + 180) / 0.25); j = int((y + 90) / 0.25); x0 = -180 + 0.25 * i; y0 = -90 + 0.25 * j
    x1 = x0 + 0.25; if (x1 >= 180) x1 -= 360
    printf "%.2f %.2f %.2f %.2f %.6f %.6f\n", x0, x1, y0, y0 + 0.25, (x - x0) / 0.25, (y - y0) / 0.25 }')
  n00=$(gdallocationinfo -valonly -geoloc "$geoid" "$x0" "$y0")
  n10=$(gdallocationinfo -valonly -geoloc "$geoid" "$x1" "$y0")
  n01=$(gdallocationinfo -valonly -geoloc "$geoid" "$x0" "$y1")
  n11=$(gdallocationinfo -valonly -geoloc "$geoid" "$x1" "$y1")
  awk -v l="$label" -v x="$lon" -v y="$lat" -v H="$H" -v h="$h" -v fx="$fx" -v fy="$fy" \
    -v a="$n00" -v b="$n10" -v c="$n01" -v d="$n11" 'BEGIN {
    N = (1 - fy) * ((1 - fx) * a + fx * b) + fy * ((1 - fx) * c + fx * d)
    printf "globe_scene.sh:   %-12s (%9.3f, %8.3f): H %8.1f  h %8.1f  h - H %8.3f  EGM96 N %8.3f\n",
      l, x, y, H, h, h - H, N }'
done <"$tmp/points.txt"
if ! awk -v d="$maxdev" 'BEGIN { exit !(d < 0.01) }'; then
  echo "globe_scene.sh: the geoid shift differs from EGM96 by up to $maxdev m (> 0.01 m)" >&2
  exit 1
fi

# 6. The scene file (format to be settled).
cat >"$out/scene.json" <<'EOF'
{
  "name": "globe: South America, Antarctica, Russia, Fiji",
  "frame": "globe",
  "terrain": {"dem": "dem.tif", "vertical_datum": "ellipsoid"},
  "camera": {"eye": {"lon": -62.0, "lat": -28.0, "h": 9000000.0}, "target": {"lon": -62.0, "lat": -28.0, "h": 0.0},
             "fov_y_deg": 45.0},
  "layers": [
    {"name": "countries", "kind": "polygon", "source": "countries.gpkg",
     "style": {"color": "#4e79a7", "opacity": 0.45}}
  ]
}
EOF

range=$(gdalinfo -stats "$out/dem.tif" 2>/dev/null |
  sed -n 's/.*Minimum=\([-0-9.]*\), Maximum=\([-0-9.]*\).*/\1 \2/p' | head -1)
rm -f "$out/dem.tif.aux.xml"
read -r hmin hmax <<<"$range"
echo "globe_scene.sh: dem.tif ${ncols} x ${nrows} cells of ${res}° (GSHHG $gshhg), Float32, heights" \
  "above the WGS 84 ellipsoid from $hmin to $hmax m, $(stat -c %s "$out/dem.tif") bytes"
echo "globe_scene.sh: wrote $out/countries.gpkg, $out/dem.tif, $out/scene.json in $((SECONDS - start)) s"
