#!/usr/bin/env bash
# A local PostgreSQL for the lab mirror (issue 30): a throwaway or a small lab's cluster in one
# directory, with the roles and the schema imubench needs.
#
#   tools/lab-db.sh init DIR [PORT]   initdb into DIR/data, start on 127.0.0.1:PORT (5433),
#                                     create database "lab", the schema and the read-only login
#                                     lab_read (its libpq password file for the readers:
#                                     DIR/secrets/lab_read.pgpass, give it as PGPASSFILE)
#   tools/lab-db.sh add-bench DIR NAME [OWNER]
#                                     a writer role NAME for one bench; its password goes to
#                                     DIR/secrets/NAME.pass (mode 0600, owned by OWNER: the
#                                     daemon's user, default the caller)
#   tools/lab-db.sh schema DIR        apply the migrations of lab/migrations/ not yet applied
#   tools/lab-db.sh start|stop DIR    start or stop the cluster (stop: fast mode)
#   tools/lab-db.sh uri DIR ROLE      the connection URI for ROLE (no password in it)
#   tools/lab-db.sh psql DIR [ARGS]   psql as the cluster's superuser, on its private socket
#
# The cluster runs as an unprivileged user: initdb refuses root, so when called as root it runs
# as $LAB_DB_USER (default "postgres", the Debian package's user). Its superuser "lab_admin"
# logs in only over the socket in DIR/run (mode 0700); TCP logins (the benches, the readers)
# need a password (scram-sha-256). Passwords are generated here and never printed.
set -euo pipefail

PGBIN=${PGBIN:-/usr/lib/postgresql/15/bin}
HERE=$(cd "$(dirname "$0")/.." && pwd)
MIGRATIONS=("$HERE"/lab/migrations/[0-9][0-9][0-9][0-9]_*.sql)

die() { echo "lab-db.sh: $*" >&2; exit 1; }
usage() { sed -n '5,20p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }

cluster_user() {
  if [ "$(id -u)" -eq 0 ]; then echo "${LAB_DB_USER:-postgres}"; else id -un; fi
}
# Runs a command as the cluster's user.
as_cluster() {
  if [ "$(id -u)" -eq 0 ]; then runuser -u "$(cluster_user)" -- "$@"; else "$@"; fi
}
port_of() { cat "$1/port"; }
admin_psql() {
  local dir=$1; shift
  psql -X -q -v ON_ERROR_STOP=1 -h "$dir/run" -p "$(port_of "$dir")" -U lab_admin "$@"
}
new_password() { head -c 24 /dev/urandom | base64 | tr -d '/+=\n'; }
check_name() {
  [[ $1 =~ ^[a-z][a-z0-9_]{0,40}$ ]] || die "'$1' is not a valid bench name ([a-z][a-z0-9_]*)"
  case $1 in lab_admin | lab_writer | lab_reader | postgres) die "'$1' is reserved" ;; esac
}

cmd_start() {
  local dir=$1
  [ -f "$dir/data/PG_VERSION" ] || die "$dir is not a lab cluster (run init first)"
  as_cluster "$PGBIN/pg_ctl" -D "$dir/data" -l "$dir/postgresql.log" -w -t 60 \
    -o "-p $(port_of "$dir") -k $dir/run -h 127.0.0.1" start >/dev/null
}
cmd_stop() {
  as_cluster "$PGBIN/pg_ctl" -D "$1/data" -m fast -w -t 60 stop >/dev/null
}

cmd_schema() {
  local dir=$1 have m n
  have=0
  if [ "$(admin_psql "$dir" -d lab -At -c "SELECT to_regclass('lab.schema_version') IS NOT NULL")" = t ]; then
    have=$(admin_psql "$dir" -d lab -At -c "SELECT coalesce(max(version), 0) FROM lab.schema_version")
  fi
  for m in "${MIGRATIONS[@]}"; do
    n=$(basename "$m"); n=$((10#${n%%_*}))
    if ((n > have)); then admin_psql "$dir" -d lab -1 -f "$m"; fi
  done
}

cmd_add_bench() {
  local dir=$1 name=$2 owner=${3:-$(id -un)} pw
  check_name "$name"
  pw=$(new_password)
  mkdir -p "$dir/secrets"
  chmod 700 "$dir/secrets"
  (umask 077 && printf '%s\n' "$pw" >"$dir/secrets/$name.pass")
  chown "$owner" "$dir/secrets/$name.pass"
  # The password reaches psql through its environment (\getenv), never through argv.
  NEW_PW=$pw admin_psql "$dir" -d lab -v name="$name" <<'SQL'
\getenv pw NEW_PW
SELECT format('CREATE ROLE %I LOGIN PASSWORD %L IN ROLE lab_writer', :'name', :'pw')
  WHERE NOT EXISTS (SELECT FROM pg_roles WHERE rolname = :'name') \gexec
SELECT format('ALTER ROLE %I PASSWORD %L', :'name', :'pw') \gexec
SQL
}

cmd_init() {
  local dir=$1 port=${2:-5433} user
  user=$(cluster_user)
  [ ! -e "$dir/data" ] || die "$dir/data exists already"
  mkdir -p "$dir/run"
  echo "$port" >"$dir/port"
  chown "$user" "$dir" "$dir/run"
  chmod 700 "$dir/run"
  as_cluster test -w "$dir" || die "$dir must be reachable and writable by $user"
  as_cluster "$PGBIN/initdb" -D "$dir/data" -U lab_admin --auth-local=trust \
    --auth-host=scram-sha-256 -E UTF8 --locale=C.UTF-8 >"$dir/initdb.log" 2>&1 ||
    die "initdb failed: see $dir/initdb.log"
  cmd_start "$dir"
  admin_psql "$dir" -d postgres -c "CREATE DATABASE lab"
  cmd_schema "$dir"
  # The lab scripts' read-only login.
  local pw
  pw=$(new_password)
  mkdir -p "$dir/secrets"
  chmod 700 "$dir/secrets"
  (umask 077 && printf '%s\n' "$pw" >"$dir/secrets/lab_read.pass" &&
    printf '127.0.0.1:%s:lab:lab_read:%s\n' "$(port_of "$dir")" "$pw" >"$dir/secrets/lab_read.pgpass")
  NEW_PW=$pw admin_psql "$dir" -d lab <<'SQL'
\getenv pw NEW_PW
SELECT format('CREATE ROLE lab_read LOGIN PASSWORD %L IN ROLE lab_reader', :'pw') \gexec
SQL
  echo "lab database: $(cmd_uri "$dir" lab_read) (read-only; for the readers:" \
    "PGPASSFILE=$dir/secrets/lab_read.pgpass)"
}

cmd_uri() { echo "postgresql://$2@127.0.0.1:$(port_of "$1")/lab"; }

[ $# -ge 2 ] || usage
cmd=$1; dir=$(realpath -m "$2"); shift 2
case $cmd in
  init) cmd_init "$dir" "$@" ;;
  add-bench) [ $# -ge 1 ] || usage; cmd_add_bench "$dir" "$@" ;;
  schema) cmd_schema "$dir" ;;
  start) cmd_start "$dir" ;;
  stop) cmd_stop "$dir" ;;
  uri) [ $# -ge 1 ] || usage; cmd_uri "$dir" "$1" ;;
  psql) admin_psql "$dir" -d lab "$@" ;;
  *) usage ;;
esac
