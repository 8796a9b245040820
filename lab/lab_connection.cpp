#include "lab/lab_connection.h"

#include <sys/stat.h>
#include <unistd.h>

#include <fstream>
#include <vector>

namespace imubench::lab {
namespace {

std::string firstLine(const char* text) {
  std::string s = text != nullptr ? text : "";
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  // libpq's connection errors are "connection to server ... failed: FATAL:  why"; keep it whole
  // but on one line.
  for (char& c : s) {
    if (c == '\n') c = ' ';
  }
  return s;
}

struct ConninfoOptionsDeleter {
  void operator()(PQconninfoOption* o) const { PQconninfoFree(o); }
};

}  // namespace

int LabSchemaVersion() {
  return IMUBENCH_LAB_SCHEMA_VERSION;
}

bool LabEndpoint::IsValid(std::string* why) const {
  if (conninfo.empty()) {
    *why = "the lab database's connection string is empty";
    return false;
  }
  if (connect_timeout_s < 1 || statement_timeout_ms < 100) {
    *why = "connect_timeout_s must be >= 1 and statement_timeout_ms >= 100";
    return false;
  }
  return true;
}

Status checkConninfo(const std::string& conninfo) {
  char* err = nullptr;
  std::unique_ptr<PQconninfoOption, ConninfoOptionsDeleter> opts(
      PQconninfoParse(conninfo.c_str(), &err));
  if (!opts) {
    std::string why = err != nullptr ? firstLine(err) : "cannot parse it";
    PQfreemem(err);
    return Status::Error("the lab database's connection string is invalid: " + why);
  }
  for (const PQconninfoOption* o = opts.get(); o->keyword != nullptr; ++o) {
    if (std::string(o->keyword) == "password" && o->val != nullptr && o->val[0] != '\0') {
      return Status::Error(
          "the lab database's connection string carries a password: put it in the file named "
          "by [lab] password_file (mode 0600) or in libpq's password file, never in the bench "
          "file");
    }
  }
  return Status::Ok();
}

Result<std::string> readPasswordFile(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    return Result<std::string>::Error(path + ": cannot read the lab password file");
  }
  if (st.st_uid != ::geteuid() || (st.st_mode & 077) != 0) {
    return Result<std::string>::Error(
        path +
        ": the lab password file must belong to the daemon's user and be readable by it "
        "only (chmod 600)");
  }
  std::ifstream in(path);
  std::string line;
  if (!in || !std::getline(in, line) || line.empty()) {
    return Result<std::string>::Error(path + ": the lab password file is empty or unreadable");
  }
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return {Status::Ok(), line};
}

const char* labFaultName(LabFault fault) {
  switch (fault) {
    case LabFault::kNone:
      return "none";
    case LabFault::kConfig:
      return "configuration";
    case LabFault::kUnreachable:
      return "unreachable";
    case LabFault::kAuth:
      return "authentication";
    case LabFault::kRights:
      return "rights";
    case LabFault::kSchema:
      return "schema";
    case LabFault::kOther:
      return "error";
  }
  return "error";
}

LabError connectLab(const LabEndpoint& endpoint, const char* application_name, PgConn* conn) {
  conn->reset();
  std::string why;
  if (!endpoint.IsValid(&why)) return {LabFault::kConfig, why};
  if (Status st = checkConninfo(endpoint.conninfo); !st.ok) return {LabFault::kConfig, st.message};
  std::string password;
  if (!endpoint.password_file.empty()) {
    auto pw = readPasswordFile(endpoint.password_file);
    if (!pw.ok()) return {LabFault::kConfig, pw.status.message};
    password = std::move(pw.value);
  }
  const std::string timeout = std::to_string(endpoint.connect_timeout_s);
  const std::string options =
      "-c statement_timeout=" + std::to_string(endpoint.statement_timeout_ms);
  // dbname first (expanded), so the settings after it override the string's.
  std::vector<const char*> keys = {
      "dbname",     "connect_timeout", "application_name",    "options",
      "keepalives", "keepalives_idle", "keepalives_interval", "keepalives_count"};
  std::vector<const char*> values = {endpoint.conninfo.c_str(),
                                     timeout.c_str(),
                                     application_name,
                                     options.c_str(),
                                     "1",
                                     "5",
                                     "2",
                                     "3"};
  if (!password.empty()) {
    keys.push_back("password");
    values.push_back(password.c_str());
  }
  keys.push_back(nullptr);
  values.push_back(nullptr);
  PgConn c(PQconnectdbParams(keys.data(), values.data(), 1));
  if (!c) return {LabFault::kUnreachable, "cannot allocate a libpq connection"};
  if (PQstatus(c.get()) != CONNECTION_OK) {
    const std::string msg = firstLine(PQerrorMessage(c.get()));
    const bool auth = msg.find("password authentication failed") != std::string::npos ||
                      msg.find("no password supplied") != std::string::npos ||
                      (msg.find("role \"") != std::string::npos &&
                       msg.find("does not exist") != std::string::npos);
    return {auth ? LabFault::kAuth : LabFault::kUnreachable, msg};
  }
  // The server's notices (e.g. "terminating connection due to administrator command") come
  // back as errors where they matter; libpq must not print them on the daemon's stderr.
  PQsetNoticeProcessor(
      c.get(), [](void*, const char*) {}, nullptr);
  *conn = std::move(c);
  return {};
}

LabError statementError(PGconn* conn, const PGresult* res, const std::string& what) {
  const char* state = res != nullptr ? PQresultErrorField(res, PG_DIAG_SQLSTATE) : nullptr;
  const std::string code = state != nullptr ? state : "";
  std::string msg = firstLine(res != nullptr ? PQresultErrorMessage(res) : PQerrorMessage(conn));
  if (msg.empty()) msg = firstLine(PQerrorMessage(conn));
  LabFault fault = LabFault::kOther;
  if (PQstatus(conn) != CONNECTION_OK || code.rfind("08", 0) == 0 || code.rfind("57P", 0) == 0) {
    fault = LabFault::kUnreachable;
  } else if (code == "42501") {
    fault = LabFault::kRights;
  } else if (code == "42P01" || code == "3F000") {
    fault = LabFault::kSchema;
  } else if (code.rfind("28", 0) == 0) {
    fault = LabFault::kAuth;
  }
  return {fault, what + ": " + msg};
}

LabError checkLabSchema(PGconn* conn) {
  PgResult r(PQexec(conn, "SELECT max(version) FROM lab.schema_version"));
  if (PQresultStatus(r.get()) != PGRES_TUPLES_OK) {
    LabError e = statementError(conn, r.get(), "cannot read the lab schema version");
    if (e.fault == LabFault::kSchema) {
      e.message += " (no lab schema: create it with tools/lab-db.sh schema)";
    }
    return e;
  }
  const int have = PQgetisnull(r.get(), 0, 0) ? 0 : std::atoi(PQgetvalue(r.get(), 0, 0));
  const int want = LabSchemaVersion();
  if (have < want) {
    return {LabFault::kSchema, "the lab schema is version " + std::to_string(have) +
                                   ", older than this imubench's " + std::to_string(want) +
                                   ": migrate it with tools/lab-db.sh schema"};
  }
  if (have > want) {
    return {LabFault::kSchema, "the lab schema is version " + std::to_string(have) +
                                   ", newer than this imubench's " + std::to_string(want) +
                                   ": update imubench on this bench"};
  }
  return {};
}

}  // namespace imubench::lab
