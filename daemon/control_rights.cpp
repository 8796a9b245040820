#include "daemon/control_rights.h"

#include <fcntl.h>
#include <grp.h>
#include <pwd.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <functional>

#include "io/enum_names.h"

namespace imubench::daemon {
namespace {

// getpwuid_r's buffer: sysconf's hint, or 16 KiB when it has none.
constexpr long kDefaultPwBuffer = 16 * 1024;
// Supplementary groups looked up at most: far beyond NGROUPS_MAX of a usual system.
constexpr int kMaxGroups = 4096;

std::string groupText(const NamedGroup& g) {
  return g.name + " (gid " + std::to_string(g.gid) + ")";
}

std::optional<std::string> decide(const ControlRights& rights, const PeerCredentials& peer,
                                  Command command,
                                  const std::function<std::vector<gid_t>()>& groups) {
  const CommandClass cls = commandClass(command);
  if (cls == CommandClass::kAnyone || !rights.command_group) return std::nullopt;
  if (cls == CommandClass::kRead && !rights.read_group) return std::nullopt;
  const std::string what = std::string(commandName(command)) + ": forbidden";
  if (!peer.known) return what + " (the peer's credentials are unknown)";
  if (peer.uid == 0 || peer.uid == rights.daemon_uid) return std::nullopt;
  std::vector<gid_t> needed = {rights.command_group->gid};
  if (cls == CommandClass::kRead) needed.push_back(rights.read_group->gid);
  const auto member = [&needed](gid_t g) {
    return std::find(needed.begin(), needed.end(), g) != needed.end();
  };
  if (member(peer.gid)) return std::nullopt;
  const std::vector<gid_t> all = groups();
  if (std::any_of(all.begin(), all.end(), member)) return std::nullopt;
  std::string need = "group " + groupText(*rights.command_group);
  if (cls == CommandClass::kRead) need = "group " + groupText(*rights.read_group) + " or " + need;
  const char* doing = cls == CommandClass::kRead ? "reading" : "commanding the bench";
  return what + " for uid " + std::to_string(peer.uid) + ": " + doing + " needs " + need;
}

}  // namespace

CommandClass commandClass(Command c) {
  switch (c) {
    case Command::kStop:
    case Command::kPing:
      return CommandClass::kAnyone;
    case Command::kStatus:
    case Command::kSubscribe:
    case Command::kUnsubscribe:
    case Command::kResults:
    case Command::kExport:
    case Command::kListPlans:
    case Command::kValidatePlan:
    case Command::kQueueList:
      return CommandClass::kRead;
    case Command::kStart:
    case Command::kPause:
    case Command::kResume:
    case Command::kAbort:
    case Command::kRearm:
    case Command::kQueueMove:
    case Command::kQueueRemove:
    case Command::kQueueResume:
    case Command::kQueueAccept:
      return CommandClass::kCommand;
  }
  return CommandClass::kCommand;  // a command added without a class needs the most rights
}

constexpr io::Named<CommandClass> kCommandClassNames[] = {
    {CommandClass::kAnyone, "anyone"},
    {CommandClass::kRead, "read"},
    {CommandClass::kCommand, "command"},
};

const char* commandClassName(CommandClass c) {
  return io::nameOf(kCommandClassNames, c, "command");
}

std::vector<gid_t> peerGroups(const PeerCredentials& peer) {
  std::vector<gid_t> out = {peer.gid};
  if (!peer.known) return {};
  long hint = ::sysconf(_SC_GETPW_R_SIZE_MAX);
  std::vector<char> buf(static_cast<std::size_t>(hint > 0 ? hint : kDefaultPwBuffer));
  passwd pw{};
  passwd* found = nullptr;
  if (::getpwuid_r(peer.uid, &pw, buf.data(), buf.size(), &found) != 0 || found == nullptr)
    return out;
  int n = kMaxGroups;
  std::vector<gid_t> groups(static_cast<std::size_t>(n));
  if (::getgrouplist(pw.pw_name, peer.gid, groups.data(), &n) < 0) return out;
  groups.resize(static_cast<std::size_t>(std::max(n, 0)));
  return groups;
}

std::optional<std::string> refuseCommand(const ControlRights& rights, const PeerCredentials& peer,
                                         Command command, const std::vector<gid_t>& groups) {
  return decide(rights, peer, command, [&groups] { return groups; });
}

std::optional<std::string> checkCommandRights(const ControlRights& rights,
                                              const PeerCredentials& peer, Command command) {
  return decide(rights, peer, command, [&peer] { return peerGroups(peer); });
}

std::optional<NamedGroup> fileGroup(const ControlRights& rights) {
  return rights.read_group ? rights.read_group : rights.command_group;
}

Status shareWithGroup(const std::string& path, const std::optional<NamedGroup>& group,
                      mode_t mode) {
  if (group && ::lchown(path.c_str(), static_cast<uid_t>(-1), group->gid) != 0) {
    return Status::Error(path + ": cannot give it to group " + groupText(*group) + " (" +
                         std::strerror(errno) +
                         "; the daemon's user must be a member of that group, or root)");
  }
  if (::fchmodat(AT_FDCWD, path.c_str(), mode, 0) != 0 && errno != ENOENT) {
    char octal[8];
    std::snprintf(octal, sizeof octal, "%04o", static_cast<unsigned>(mode));
    return Status::Error(path + ": chmod " + octal + ": " + std::strerror(errno));
  }
  return Status::Ok();
}

Status shareDirWithGroup(const std::string& dir, const std::optional<NamedGroup>& group) {
  if (Status s = shareWithGroup(dir, group, 0750); !s.ok) return s;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
    if (!entry.is_regular_file(ec) || entry.is_symlink(ec)) continue;
    if (Status s = shareWithGroup(entry.path().string(), group, 0640); !s.ok) return s;
  }
  if (ec) return Status::Error(dir + ": " + ec.message());
  return Status::Ok();
}

bool mayCommand(const ControlRights& rights, const PeerCredentials& peer) {
  return !checkCommandRights(rights, peer, Command::kAbort).has_value();
}

}  // namespace imubench::daemon
