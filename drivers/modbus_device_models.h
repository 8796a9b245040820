// Register maps of the virtual table and chamber for the Modbus server: the same device file
// the driver uses says where each value lives and how it is scaled.
#pragma once

#include "drivers/modbus_server.h"
#include "drivers/virtual_world.h"

namespace imubench::drivers {

class VirtualTableRegisters final : public ModbusDeviceModel {
 public:
  VirtualTableRegisters(VirtualWorld& world, const TableDeviceSpec& spec, EventSink sink);
  int holdingCount() const override { return holding_; }
  int inputCount() const override { return input_; }
  void refresh(_modbus_mapping_t* m) override;
  void written(_modbus_mapping_t* m, int address, int count) override;

 private:
  VirtualWorld& world_;
  TableDeviceSpec spec_;
  EventSink sink_;
  int holding_ = 0, input_ = 0;
};

class VirtualChamberRegisters final : public ModbusDeviceModel {
 public:
  VirtualChamberRegisters(VirtualWorld& world, const ChamberDeviceSpec& spec, EventSink sink);
  int holdingCount() const override { return holding_; }
  int inputCount() const override { return input_; }
  void refresh(_modbus_mapping_t* m) override;
  void written(_modbus_mapping_t* m, int address, int count) override;

 private:
  VirtualWorld& world_;
  ChamberDeviceSpec spec_;
  EventSink sink_;
  int holding_ = 0, input_ = 0;
};

}  // namespace imubench::drivers
