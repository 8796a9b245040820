// A throwaway PostgreSQL cluster for the lab mirror's tests (issue 30): tools/lab-db.sh init in a
// fresh temporary directory on a free port, stopped and removed at the end. A real server from
// the Debian postgresql-15 package, never a mock; when it cannot be started the test FAILS (it
// never skips): the lab mode is only shown where a server ran.
#pragma once

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "lab/lab_connection.h"

namespace imubench::lab::testing {

inline int freeTcpPort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = 0;
  socklen_t len = sizeof a;
  int port = 0;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) == 0) {
    port = ntohs(a.sin_port);
  }
  ::close(fd);
  return port;
}

inline int shell(const std::string& cmd) {
  const int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

class LabCluster {
 public:
  LabCluster() {
    const char* base = std::getenv("TMPDIR");
    std::string templ = std::string(base != nullptr ? base : "/tmp") + "/imubench-lab-XXXXXX";
    if (mkdtemp(templ.data()) == nullptr) {
      ADD_FAILURE() << "mkdtemp failed";
      return;
    }
    root_ = templ;
    // The cluster runs as an unprivileged user (initdb refuses root): it must reach the dir.
    std::filesystem::permissions(root_, std::filesystem::perms(0755));
    dir_ = (root_ / "cluster").string();
    port_ = freeTcpPort();
    const std::string init = script() + " init " + dir_ + " " + std::to_string(port_) + " > " +
                             (root_ / "init.log").string() + " 2>&1";
    started_ = shell(init) == 0;
    if (!started_) {
      std::ifstream log(root_ / "init.log");
      std::string text;
      for (std::string line; std::getline(log, line);) text += line + "\n";
      ADD_FAILURE() << "cannot start a PostgreSQL cluster (" << init << "):\n" << text;
    }
  }
  ~LabCluster() {
    if (started_) shell(script() + " stop " + dir_ + " >/dev/null 2>&1");
    std::error_code ec;
    std::filesystem::remove_all(root_, ec);
  }
  LabCluster(const LabCluster&) = delete;
  LabCluster& operator=(const LabCluster&) = delete;

  bool started() const { return started_; }
  const std::string& dir() const { return dir_; }
  std::string root() const { return root_.string(); }
  int port() const { return port_; }
  static std::string script() { return std::string(IMUBENCH_SOURCE_DIR) + "/tools/lab-db.sh"; }

  // A writer role for a bench; returns its endpoint (password file from lab-db.sh).
  LabEndpoint addBench(const std::string& name) const {
    EXPECT_EQ(shell(script() + " add-bench " + dir_ + " " + name), 0) << "add-bench " << name;
    return endpoint(name, dir_ + "/secrets/" + name + ".pass");
  }
  LabEndpoint endpoint(const std::string& role, const std::string& password_file) const {
    LabEndpoint e;
    e.conninfo = "postgresql://" + role + "@127.0.0.1:" + std::to_string(port_) + "/lab";
    e.password_file = password_file;
    e.connect_timeout_s = 2;
    return e;
  }
  LabEndpoint reader() const { return endpoint("lab_read", dir_ + "/secrets/lab_read.pass"); }
  // The superuser, over the cluster's private socket (no password).
  std::string adminConninfo() const {
    return "host=" + dir_ + "/run port=" + std::to_string(port_) + " user=lab_admin dbname=lab";
  }
  int stop() const { return shell(script() + " stop " + dir_); }
  int start() const { return shell(script() + " start " + dir_); }
  // Runs SQL as the superuser; returns the first value of the first row ("" when none).
  std::string admin(const std::string& sql) const {
    PgConn c(PQconnectdb(adminConninfo().c_str()));
    if (PQstatus(c.get()) != CONNECTION_OK) {
      ADD_FAILURE() << "admin connection: " << PQerrorMessage(c.get());
      return "";
    }
    PgResult r(PQexec(c.get(), sql.c_str()));
    const auto st = PQresultStatus(r.get());
    if (st != PGRES_TUPLES_OK && st != PGRES_COMMAND_OK) {
      ADD_FAILURE() << sql << ": " << PQresultErrorMessage(r.get());
      return "";
    }
    return st == PGRES_TUPLES_OK && PQntuples(r.get()) > 0 ? PQgetvalue(r.get(), 0, 0) : "";
  }

 private:
  std::filesystem::path root_;
  std::string dir_;
  int port_ = 0;
  bool started_ = false;
};

}  // namespace imubench::lab::testing
