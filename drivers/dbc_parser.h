// Reader for the message/signal subset of DBC files (Vector's CAN database format), so a
// user's existing DBC for their IMU describes the frame layout.
//
// Grammar accepted (one statement per line unless noted; "..." are double-quoted strings that
// may span lines; numbers may be decimal, hex 0x.., or floating point):
//
//   VERSION "text"
//   NS_ :                                 followed by indented keyword lines (ignored)
//   BS_ : [baudrate : btr1 , btr2]        (ignored)
//   BU_ : node node ...
//   BO_ <id> <name> : <dlc> <transmitter>
//       <id> decimal; bit 31 set (0x80000000 | id) marks a 29-bit identifier. <dlc> is the
//       payload length in bytes (up to 64: a length over 8 makes the message CAN FD).
//   SG_ <name> : <start>|<length>@<order><sign> (<factor>,<offset>) [<min>|<max>] "<unit>"
//   <rx>,<rx>
//       follows its BO_; <order> 1 = little-endian (Intel), 0 = big-endian (Motorola);
//       <sign> + unsigned, - signed (two's complement).
//   SIG_VALTYPE_ <id> <signal> : <1|2> ;  1 = IEEE float (32 bit), 2 = IEEE double (64 bit)
//   CM_, BA_DEF_, BA_DEF_DEF_, BA_, VAL_, VAL_TABLE_, BO_TX_BU_, EV_, SIG_GROUP_ ... ;
//       descriptive statements that do not change decoding: read up to their ';' and ignored.
//
// Example (SBG Systems ECAN IMU accelerations, little-endian, 0.01 m/s^2 per LSB):
//
//   BO_ 289 IMU_ACCEL: 6 SBG
//    SG_ ACCEL_X : 0|16@1- (0.01,0) [-327.68|327.67] "m/s2" Vector__XXX
//    SG_ ACCEL_Y : 16|16@1- (0.01,0) [-327.68|327.67] "m/s2" Vector__XXX
//
// Refused with file line and reason (never guessed): multiplexed signals (M, m<n>, SG_MUL_VAL_),
// signal type references (SGTYPE_, SIG_TYPE_REF_), SG_ outside a BO_, unknown statements,
// malformed numbers, signals that do not fit their message, duplicate message ids or names.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "drivers/can_signal.h"
#include "io/toml_diagnostics.h"

namespace imubench::drivers {

struct DbcSignal {
  std::string name;
  SignalCoding coding;  // factor/offset as written (in the DBC's unit, not yet SI)
  double minimum = 0.0;
  double maximum = 0.0;
  std::string unit;
  int line = 0;  // where it was defined, for later diagnostics
};

struct DbcMessage {
  std::uint32_t id = 0;  // without the extended-id flag
  bool extended = false;
  std::string name;
  int length = 0;  // payload bytes
  std::string transmitter;
  std::vector<DbcSignal> signals;
  int line = 0;
  const DbcSignal* findSignal(std::string_view signal_name) const;
};

struct DbcDatabase {
  std::string version;
  std::vector<std::string> nodes;
  std::vector<DbcMessage> messages;
  const DbcMessage* findMessage(std::string_view message_name) const;
};

// Parses DBC text. Errors are reported in diag (file:line:column: reason); returns nullopt
// when there was any error.
std::optional<DbcDatabase> parseDbc(std::string_view text, io::Diagnostics& diag);
// Reads and parses a file; a missing file is a diagnostic too.
std::optional<DbcDatabase> loadDbcFile(const std::string& path, io::Diagnostics& diag);

}  // namespace imubench::drivers
