#!/usr/bin/env bash
# Runs a test program against a real PostgreSQL + PostGIS server of its own: a new cluster in a
# temporary folder, listening on a Unix socket there only (no TCP port, so parallel runs cannot
# collide), the PostGIS extension created, the Olinda tracts and streets loaded with ogr2ogr.
# The program finds the server through STENCIL_GIS_PG (an OGR "PG:" connection string). The
# server is stopped and the folder removed however the program ends.
#   with_postgis.sh SAMPLES_DIR PROGRAM [ARGS...]
set -euo pipefail
samples=$1
shift

bin=$(ls -d /usr/lib/postgresql/*/bin 2>/dev/null | sort -V | tail -1)
if [ -z "$bin" ] || [ ! -x "$bin/initdb" ]; then
  echo "with_postgis: no PostgreSQL server binaries (scripts/install-deps.sh installs them)" >&2
  exit 1
fi

dir=$(mktemp -d /tmp/stencil-gis-pg.XXXXXX)
chmod 755 "$dir"
# PostgreSQL refuses to run as root: as root, the cluster belongs to the postgres user.
as_owner=()
if [ "$(id -u)" -eq 0 ]; then
  as_owner=(runuser -u postgres --)
  chown postgres "$dir"
fi
port=5432
cleanup() {
  "${as_owner[@]}" "$bin/pg_ctl" -D "$dir/data" -m immediate stop >/dev/null 2>&1 || true
  rm -rf "$dir"
}
trap cleanup EXIT

"${as_owner[@]}" "$bin/initdb" -D "$dir/data" -A trust -U postgres >"$dir/initdb.log" 2>&1 || {
  cat "$dir/initdb.log" >&2
  exit 1
}
"${as_owner[@]}" "$bin/pg_ctl" -D "$dir/data" -l "$dir/server.log" -w -t 60 \
  -o "-c listen_addresses='' -k $dir -p $port -c fsync=off" start >/dev/null || {
  cat "$dir/server.log" >&2
  exit 1
}
psql -h "$dir" -p "$port" -U postgres -d postgres -v ON_ERROR_STOP=1 -q -c "CREATE EXTENSION postgis;"
conn="PG:host=$dir port=$port dbname=postgres user=postgres"
ogr2ogr -f PostgreSQL "$conn" "$samples/olinda/olinda1.shp" -nln olinda_tracts -lco FID=fid -preserve_fid
ogr2ogr -f PostgreSQL "$conn" "$samples/olinda/olinda_tract_boundaries.geojson" -nln olinda_streets \
  -lco FID=fid -preserve_fid

STENCIL_GIS_PG="$conn" "$@"
