// A libpq connection to the lab database (issue 30), shared by the shipper and the readers.
//
// The connection string (`[lab] database` in the bench file, or `--db postgresql://...`) must not
// carry a password: credentials come from a file only the daemon's user can read
// (LabEndpoint::password_file) or from libpq's own service and password files (~/.pgpass,
// PGPASSFILE, PGSERVICEFILE). Nothing here logs or returns a password; libpq's messages name
// host, port and role only.
#pragma once

#include <libpq-fe.h>

#include <memory>
#include <string>

#include "base/status.h"

namespace imubench::lab {

// The migrations in lab/migrations/ this build knows (their count).
int LabSchemaVersion();

struct LabEndpoint {
  // A libpq connection URI or key=value string without a password, e.g.
  // "postgresql://bench1@127.0.0.1:5433/lab".
  std::string conninfo;
  // A file holding the password (its first line), owned by the process's user and readable by
  // it only (mode 0600 or 0400); empty: libpq's password/service files or no password.
  std::string password_file;
  // How long a connection attempt may take, s: a partitioned network must not hold the
  // shipper longer than this before it reports the fault and retries.
  int connect_timeout_s = 5;
  // Statement timeout, ms: a hung server fails the batch instead of holding it forever.
  int statement_timeout_ms = 15000;

  bool IsValid(std::string* why) const;
};

// Refuses a connection string that carries a password or does not parse (the reason names the
// string's problem, never its text past the scheme).
Status checkConninfo(const std::string& conninfo);

// Reads the password file (see LabEndpoint::password_file); refuses one that others can read.
Result<std::string> readPasswordFile(const std::string& path);

struct PgConnDeleter {
  void operator()(PGconn* c) const { PQfinish(c); }
};
struct PgResultDeleter {
  void operator()(PGresult* r) const { PQclear(r); }
};
using PgConn = std::unique_ptr<PGconn, PgConnDeleter>;
using PgResult = std::unique_ptr<PGresult, PgResultDeleter>;

// What went wrong, as the operator needs to hear it.
enum class LabFault {
  kNone,
  kConfig,       // the endpoint or password file is refused
  kUnreachable,  // no connection (down, partitioned, refused)
  kAuth,         // wrong password or unknown role
  kRights,       // the role may not write (e.g. a read-only role)
  kSchema,       // the lab schema is missing, older or newer than this imubench
  kOther,        // any other error the server reports
};
const char* labFaultName(LabFault fault);  // "unreachable", "authentication", ...

struct LabError {
  LabFault fault = LabFault::kNone;
  std::string message;  // one line
  bool ok() const { return fault == LabFault::kNone; }
};

// Connects (blocking up to connect_timeout_s). On failure *conn is null and the error says why.
LabError connectLab(const LabEndpoint& endpoint, const char* application_name, PgConn* conn);

// The error of a failed statement (res may be null: the connection failed).
LabError statementError(PGconn* conn, const PGresult* res, const std::string& what);

// The lab schema's version (max of lab.schema_version); a kSchema error when it is missing or
// differs from LabSchemaVersion().
LabError checkLabSchema(PGconn* conn);

}  // namespace imubench::lab
