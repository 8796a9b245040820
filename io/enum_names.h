// How files, logs and the control protocol spell the values of an enum, kept in one table per
// enum: the name of a value and the value of a name (for readers) come from the same rows, so
// the two directions cannot disagree.
#pragma once

#include <iterator>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

namespace imubench::io {

// One row of a name table, e.g. constexpr Named<DeviceState> kStates[] = {{kReady, "ready"}}.
template <class E, class N = const char*>
struct Named {
  E value;
  N name;
};

template <class Table>
using NamedValueOf = std::remove_cvref_t<decltype(std::begin(std::declval<Table&>())->value)>;
template <class Table>
using NamedNameOf = std::remove_cvref_t<decltype(std::begin(std::declval<Table&>())->name)>;

// The name of `value` in `table`; `unknown` when no row has it (a value cast from a number).
template <class Table>
constexpr NamedNameOf<const Table> nameOf(const Table& table, NamedValueOf<const Table> value,
                                          NamedNameOf<const Table> unknown) {
  for (const auto& row : table)
    if (row.value == value) return row.name;
  return unknown;
}

// The value named `name` in `table`; nullopt when no row has that name.
template <class Table>
constexpr std::optional<NamedValueOf<const Table>> valueOf(const Table& table,
                                                           std::string_view name) {
  for (const auto& row : table)
    if (std::string_view(row.name) == name) return row.value;
  return std::nullopt;
}

// Every name of `table` in its order, separated by `sep` ("start, pause, ..."), for messages
// that list what is accepted.
template <class Table>
std::string joinNames(const Table& table, std::string_view sep) {
  std::string out;
  for (const auto& row : table) {
    if (!out.empty()) out += sep;
    out += row.name;
  }
  return out;
}

}  // namespace imubench::io
