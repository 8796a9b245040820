// The table driver factory (drivers/table.h): the device file's transport picks the
// implementation, so the interface file (table.cpp) knows neither of them.
#include <memory>
#include <utility>

#include "drivers/table.h"
#include "drivers/table_modbus.h"
#include "drivers/table_serial.h"

namespace imubench::drivers {

std::unique_ptr<TableDriver> makeTableDriver(const TableDeviceSpec& spec, EventSink sink) {
  if (spec.transport.kind == TransportKind::kSerialScpi) {
    return std::make_unique<SerialTable>(spec, std::move(sink));
  }
  return std::make_unique<ModbusTable>(spec, std::move(sink));
}

}  // namespace imubench::drivers
