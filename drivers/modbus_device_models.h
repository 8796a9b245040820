// Register maps of the virtual table and chamber for the Modbus server: the same device file
// the driver uses says where each value lives and how it is scaled.
#pragma once

#include <utility>

#include "drivers/modbus_server.h"
#include "drivers/virtual_world.h"

namespace imubench::drivers {

// What the virtual devices' register maps share: the world they serve, their device file,
// where refusals are reported, and the register counts their map needs.
template <class Spec>
class VirtualRegisters : public ModbusDeviceModel {
 public:
  int holdingCount() const override { return holding_; }
  int inputCount() const override { return input_; }

 protected:
  VirtualRegisters(VirtualWorld& world, const Spec& spec, EventSink sink)
      : world_(world), spec_(spec), sink_(std::move(sink)) {}
  VirtualWorld& world_;
  Spec spec_;
  EventSink sink_;
  int holding_ = 0, input_ = 0;  // set by the derived constructor from the map
};

class VirtualTableRegisters final : public VirtualRegisters<TableDeviceSpec> {
 public:
  VirtualTableRegisters(VirtualWorld& world, const TableDeviceSpec& spec, EventSink sink);
  void refresh(_modbus_mapping_t* m) override;
  void written(_modbus_mapping_t* m, int address, int count) override;

 private:
  // Reports an expiry of the table's host watchdog not yet reported (under the world's lock).
  void reportWatchdog(const VirtualTable& table);
  int watchdog_reported_ = 0;
};

class VirtualChamberRegisters final : public VirtualRegisters<ChamberDeviceSpec> {
 public:
  VirtualChamberRegisters(VirtualWorld& world, const ChamberDeviceSpec& spec, EventSink sink);
  void refresh(_modbus_mapping_t* m) override;
  void written(_modbus_mapping_t* m, int address, int count) override;
};

}  // namespace imubench::drivers
