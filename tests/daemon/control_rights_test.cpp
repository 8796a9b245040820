// The control socket's rights policy (daemon/control_rights.h): which peer may send which
// command, decided from its uid, primary gid and groups; no socket involved.
#include "daemon/control_rights.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <string>
#include <vector>

namespace imubench::daemon {
namespace {

constexpr gid_t kCommandGid = 5001;
constexpr gid_t kReadGid = 5002;
constexpr gid_t kOtherGid = 5003;
constexpr uid_t kDaemonUid = 990;
constexpr uid_t kUser = 1000;

ControlRights configured(bool with_read_group) {
  ControlRights r;
  r.command_group = NamedGroup{"imubench", kCommandGid};
  if (with_read_group) r.read_group = NamedGroup{"imubench-view", kReadGid};
  r.daemon_uid = kDaemonUid;
  return r;
}

PeerCredentials peer(uid_t uid, gid_t gid) {
  return {true, uid, gid, 4242};
}

// kUser in group g both ways: as its primary gid, and as a supplementary group.
std::vector<std::pair<PeerCredentials, std::vector<gid_t>>> membersOf(gid_t g) {
  return {{peer(kUser, g), {g}}, {peer(kUser, kOtherGid), {kOtherGid, g}}};
}

const Command kCommands[] = {Command::kStart,       Command::kPause,       Command::kResume,
                             Command::kAbort,       Command::kRearm,       Command::kQueueMove,
                             Command::kQueueRemove, Command::kQueueResume, Command::kQueueAccept};
const Command kReads[] = {Command::kStatus,       Command::kSubscribe, Command::kUnsubscribe,
                          Command::kResults,      Command::kExport,    Command::kListPlans,
                          Command::kValidatePlan, Command::kQueueList};
const Command kAnyone[] = {Command::kStop, Command::kPing};

TEST(ControlRights, CommandClasses) {
  for (Command c : kCommands) EXPECT_EQ(commandClass(c), CommandClass::kCommand) << commandName(c);
  for (Command c : kReads) EXPECT_EQ(commandClass(c), CommandClass::kRead) << commandName(c);
  for (Command c : kAnyone) EXPECT_EQ(commandClass(c), CommandClass::kAnyone) << commandName(c);
}

TEST(ControlRights, WithoutGroupsEveryoneMayDoEverything) {
  const ControlRights none;
  for (Command c : {Command::kStart, Command::kAbort, Command::kStatus, Command::kStop})
    EXPECT_FALSE(refuseCommand(none, peer(kUser, kOtherGid), c, {kOtherGid}).has_value());
  EXPECT_FALSE(refuseCommand(none, PeerCredentials{}, Command::kStart, {}).has_value());
}

TEST(ControlRights, StrangerMayStopAndPingOnly) {
  const ControlRights r = configured(true);
  const PeerCredentials p = peer(kUser, kOtherGid);
  for (Command c : kAnyone) EXPECT_FALSE(refuseCommand(r, p, c, {kOtherGid})) << commandName(c);
  for (Command c : kReads) EXPECT_TRUE(refuseCommand(r, p, c, {kOtherGid})) << commandName(c);
  for (Command c : kCommands) EXPECT_TRUE(refuseCommand(r, p, c, {kOtherGid})) << commandName(c);
  // The refusal names the command, the uid and the group needed.
  const std::string m = *refuseCommand(r, p, Command::kStart, {kOtherGid});
  EXPECT_EQ(m,
            "start: forbidden for uid 1000: commanding the bench needs group imubench (gid 5001)");
  const std::string rm = *refuseCommand(r, p, Command::kStatus, {kOtherGid});
  EXPECT_NE(rm.find("status: forbidden for uid 1000"), std::string::npos) << rm;
  EXPECT_NE(rm.find("imubench-view (gid 5002) or group imubench"), std::string::npos) << rm;
}

TEST(ControlRights, ReadGroupReadsOnly) {
  const ControlRights r = configured(true);
  // By primary gid, and by a supplementary group.
  for (const auto& [p, groups] : membersOf(kReadGid)) {
    for (Command c : kReads) EXPECT_FALSE(refuseCommand(r, p, c, groups)) << commandName(c);
    for (Command c : kAnyone) EXPECT_FALSE(refuseCommand(r, p, c, groups)) << commandName(c);
    for (Command c : kCommands) EXPECT_TRUE(refuseCommand(r, p, c, groups)) << commandName(c);
  }
}

TEST(ControlRights, CommandGroupMayDoEverything) {
  const ControlRights r = configured(true);
  for (const auto& [p, groups] : membersOf(kCommandGid)) {
    for (Command c : kCommands) EXPECT_FALSE(refuseCommand(r, p, c, groups)) << commandName(c);
    for (Command c : kReads) EXPECT_FALSE(refuseCommand(r, p, c, groups)) << commandName(c);
  }
}

TEST(ControlRights, WithoutReadGroupReadingIsOpen) {
  const ControlRights r = configured(false);
  const PeerCredentials p = peer(kUser, kOtherGid);
  for (Command c : kReads) EXPECT_FALSE(refuseCommand(r, p, c, {kOtherGid})) << commandName(c);
  for (Command c : kCommands) EXPECT_TRUE(refuseCommand(r, p, c, {kOtherGid})) << commandName(c);
}

TEST(ControlRights, RootAndTheDaemonsUidMayDoEverythingUnknownPeersNothingButStop) {
  const ControlRights r = configured(true);
  for (uid_t uid : {uid_t{0}, kDaemonUid}) {
    for (Command c : kCommands)
      EXPECT_FALSE(refuseCommand(r, peer(uid, kOtherGid), c, {kOtherGid})) << commandName(c);
  }
  const PeerCredentials unknown;
  EXPECT_FALSE(refuseCommand(r, unknown, Command::kStop, {}));
  const auto m = refuseCommand(r, unknown, Command::kStatus, {});
  ASSERT_TRUE(m);
  EXPECT_NE(m->find("credentials are unknown"), std::string::npos) << *m;
}

TEST(ControlRights, PeerGroupsIncludePrimaryAndSupplementary) {
  // This process's own user: its primary gid and what getgrouplist lists for it.
  const PeerCredentials self = peer(::getuid(), ::getgid());
  const std::vector<gid_t> groups = peerGroups(self);
  EXPECT_NE(std::find(groups.begin(), groups.end(), ::getgid()), groups.end());
  // A uid without a passwd entry: just its primary gid.
  EXPECT_EQ(peerGroups(peer(4000000000u, kOtherGid)), std::vector<gid_t>{kOtherGid});
  // checkCommandRights looks the groups up itself: a stranger's uid is refused a start.
  EXPECT_TRUE(checkCommandRights(configured(true), peer(4000000000u, kOtherGid), Command::kStart));
}

}  // namespace
}  // namespace imubench::daemon
