// Who may send which command over the control socket (issue 15): the policy, kept apart from
// the socket (daemon/control_server.h knows the peer's credentials, not the commands' meaning)
// and from the daemon's dispatch, so it is decided in one place and unit-tested alone.
//
// Three classes of command:
//   anyone   stop (the emergency stop), ping: every local user who can reach the socket
//   read     status, subscribe/unsubscribe (watch), results, export, list_plans,
//            validate_plan, queue_list
//   command  start, pause, resume, abort, rearm, queue_move, queue_remove, queue_resume,
//            queue_accept
// With no command group configured (the bench file's [control] has neither command_group nor
// read_group) everyone who can reach the socket may do everything: the socket file's mode is
// the only gate (today's behaviour). With a command group, command needs membership of it; read
// needs the read group or the command group (or, without a read group, nothing). Root (uid 0)
// and the daemon's own uid may do everything. Membership: the peer's primary gid (SO_PEERCRED)
// or a supplementary group of the peer's user (its passwd entry and getgrouplist).
#pragma once

#include <sys/types.h>

#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "daemon/control_protocol.h"

namespace imubench::daemon {

// The credentials of a control connection's peer, as SO_PEERCRED gave them at accept.
struct PeerCredentials {
  bool known = false;  // false: getsockopt failed (treated as a stranger)
  uid_t uid = 0;
  gid_t gid = 0;
  pid_t pid = 0;
};

enum class CommandClass { kAnyone, kRead, kCommand };
CommandClass commandClass(Command c);
// "anyone", "read", "command".
const char* commandClassName(CommandClass c);

// A group named in the bench file, resolved when the file is loaded.
struct NamedGroup {
  std::string name;
  gid_t gid = 0;
};

struct ControlRights {
  // Members may send every command. Absent: no rights are checked at all.
  std::optional<NamedGroup> command_group;
  // Members may send read commands. Absent (with a command group): read is open to everyone
  // who reaches the socket.
  std::optional<NamedGroup> read_group;
  uid_t daemon_uid = 0;  // the daemon's own uid: allowed everything, like root
};

// The groups of a peer: its primary gid and its user's supplementary groups (empty of those
// when the uid has no passwd entry). Reads the user and group databases (NSS).
std::vector<gid_t> peerGroups(const PeerCredentials& peer);

// nullopt: allowed. Otherwise the refusal's message, naming the command, the peer's uid and the
// group needed. groups: the peer's groups (peerGroups), consulted only when needed.
std::optional<std::string> refuseCommand(const ControlRights& rights, const PeerCredentials& peer,
                                         Command command, const std::vector<gid_t>& groups);

// Whether the peer may command the bench (root, the daemon's uid, the command group; everyone
// without a command group): who gets the control socket's reserved slots.
bool mayCommand(const ControlRights& rights, const PeerCredentials& peer);

// refuseCommand with the groups looked up only when the decision needs them.
std::optional<std::string> checkCommandRights(const ControlRights& rights,
                                              const PeerCredentials& peer, Command command);

// The group the daemon's files (database, exports) belong to, so readers can read them: the
// read group, else the command group, else none (the files keep the daemon's group).
std::optional<NamedGroup> fileGroup(const ControlRights& rights);

// Gives path (not following a symlink) to `group` with `mode` (0640 files, 0750 directories):
// what readers need. Without a group only the mode is set. An error names the path, the
// group and why (a daemon not running as root must itself be a member of the group).
Status shareWithGroup(const std::string& path, const std::optional<NamedGroup>& group, mode_t mode);
// shareWithGroup on dir (0750) and every regular file directly in it (0640).
Status shareDirWithGroup(const std::string& dir, const std::optional<NamedGroup>& group);

}  // namespace imubench::daemon
