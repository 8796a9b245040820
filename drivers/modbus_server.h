// Modbus server for the virtual devices, on libmodbus' server side (modbus_mapping_new,
// modbus_receive, modbus_reply): TCP with select() over several clients at once, or RTU on a
// pseudo-terminal. What the registers mean is the ModbusDeviceModel's business; the server
// only moves bytes, applies injected link faults and reports events.
#pragma once

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <random>
#include <string>
#include <thread>

#include "drivers/device_errors.h"
#include "drivers/device_file.h"
#include "drivers/faults.h"
#include "drivers/serial_pty.h"

struct _modbus;
struct _modbus_mapping_t;

namespace imubench::drivers {

class ModbusDeviceModel {
 public:
  virtual ~ModbusDeviceModel() = default;
  // Register counts the mapping needs (highest address + 1) per bank.
  virtual int holdingCount() const = 0;
  virtual int inputCount() const = 0;
  // Called (in the server thread) before every request: write the readable registers.
  virtual void refresh(_modbus_mapping_t* m) = 0;
  // Called after a write request was applied to the mapping: act on [address, address+count).
  virtual void written(_modbus_mapping_t* m, int address, int count) = 0;
};

class ModbusServer {
 public:
  ModbusServer(ModbusDeviceModel& model, LinkFaults& faults, EventSink sink);
  ~ModbusServer();
  ModbusServer(const ModbusServer&) = delete;
  ModbusServer& operator=(const ModbusServer&) = delete;

  // TCP on host:port (port 0: an ephemeral port, see port()).
  Status startTcp(const std::string& host, int port);
  // RTU on a new pseudo-terminal; clients open ptyPath().
  Status startRtu(int unit_id);
  void stop();
  int port() const { return port_; }
  const std::string& ptyPath() const { return pty_.slavePath(); }
  // Fault injection: close every client connection now (TCP).
  void dropConnections();
  int clientCount() const { return clients_.load(); }

 private:
  void runTcp();
  void runRtu();
  // Answers one received request (rc bytes in query) on ctx, applying faults.
  void answer(_modbus* ctx, const uint8_t* query, int rc);
  bool waitWall(double seconds);  // false when stopping
  void emit(const std::string& m) const {
    if (sink_) sink_(m);
  }

  ModbusDeviceModel& model_;
  LinkFaults& faults_;
  EventSink sink_;
  _modbus* ctx_ = nullptr;
  _modbus_mapping_t* mapping_ = nullptr;
  int listen_fd_ = -1;
  int wake_[2] = {-1, -1};
  int port_ = 0;
  PseudoTerminal pty_;
  std::thread thread_;
  std::atomic<bool> stopping_{false};
  std::atomic<bool> drop_{false};
  std::atomic<int> clients_{0};
  std::mt19937 rng_{1};  // latency jitter (server thread only)
  std::mutex wait_mu_;
  std::condition_variable wait_cv_;
};

}  // namespace imubench::drivers
