#!/usr/bin/env bash
# deploy/postgres/setup.sh: prepares a production PostgreSQL cluster for VES.
#   sudo -u postgres deploy/postgres/setup.sh [--role ves] [--database ves] [--password-file F]
# Creates the login role and the database it owns, and makes records durable
# whatever the server's defaults: synchronous_commit=on for the role and the
# database (ves-server also sets it on every connection). Idempotent. The
# schema itself is created by the first ves-server (or ves-admin) that opens
# the database: migrations run under an advisory lock, so replicas can start
# together. See docs/operations.md.
set -euo pipefail

role=ves
database=ves
password_file=""
while [ $# -gt 0 ]; do
  case "$1" in
    --role) role="$2"; shift 2 ;;
    --database) database="$2"; shift 2 ;;
    --password-file) password_file="$2"; shift 2 ;;
    -h|--help) sed -n '2,9p' "$0"; exit 0 ;;
    *) echo "setup.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
for name in "$role" "$database"; do
  if ! [[ "$name" =~ ^[a-z_][a-z0-9_]{0,62}$ ]]; then
    echo "setup.sh: '$name' is not a plain lower-case identifier" >&2
    exit 2
  fi
done

psql_admin=(psql -v ON_ERROR_STOP=1 -X -q -d postgres)
password_sql=""
if [ -n "$password_file" ]; then
  [ -r "$password_file" ] || { echo "setup.sh: cannot read '$password_file'" >&2; exit 2; }
  password_sql="PASSWORD :'pw'"
fi

"${psql_admin[@]}" -v pw="$( [ -n "$password_file" ] && head -n 1 "$password_file" )" <<SQL
SELECT format('CREATE ROLE %I LOGIN', '$role')
  WHERE NOT EXISTS (SELECT 1 FROM pg_roles WHERE rolname = '$role') \gexec
ALTER ROLE "$role" WITH LOGIN $password_sql;
ALTER ROLE "$role" SET synchronous_commit = on;
SELECT format('CREATE DATABASE %I OWNER %I ENCODING ''UTF8'' TEMPLATE template0', '$database', '$role')
  WHERE NOT EXISTS (SELECT 1 FROM pg_database WHERE datname = '$database') \gexec
ALTER DATABASE "$database" SET synchronous_commit = on;
REVOKE ALL ON DATABASE "$database" FROM PUBLIC;
GRANT CONNECT, TEMPORARY ON DATABASE "$database" TO "$role";
SQL
# The role owns the public schema of its database so migrations can create tables.
psql -v ON_ERROR_STOP=1 -X -q -d "$database" -c "ALTER SCHEMA public OWNER TO \"$role\""

# Cluster-wide settings a VES deployment relies on: fsync and full-page writes
# on (the defaults), and synchronous_commit on (never 'off' or 'local' with a
# standby you count on).
for setting in fsync full_page_writes synchronous_commit; do
  value="$(psql -X -At -d postgres -c "SHOW $setting")"
  echo "setup.sh: $setting = $value"
  case "$setting:$value" in
    fsync:on|full_page_writes:on|synchronous_commit:on|synchronous_commit:remote_apply) ;;
    synchronous_commit:remote_write) ;;
    *) echo "setup.sh: WARNING: $setting should be on for durable records" >&2 ;;
  esac
done
echo "setup.sh: role '$role' and database '$database' ready;" \
  "point ves-server at postgresql://$role@HOST/$database"
