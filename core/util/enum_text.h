// One definition of a small enum's names (COLMAP's MAKE_ENUM_CLASS): each
// enum lists its values and their text once, in an EnumText specialisation
// next to the enum; both directions and the list of values come from it.
//
//   enum class Split { kTrain, kVal, kTest };
//   template <>
//   struct EnumText<Split> {
//     static constexpr const char* kKind = "split";
//     static constexpr EnumEntry<Split> kEntries[] = {
//         {Split::kTrain, "train"}, {Split::kVal, "val"}, {Split::kTest, "test"}};
//   };
//
//   EnumName(Split::kVal);        // "val"
//   ParseEnum<Split>("test");     // Split::kTest; InputError for "tset"
//   for (Split s : EnumValues<Split>()) ...
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include "core/util/error.h"

namespace furn {

template <typename E>
struct EnumEntry {
  E value;
  const char* name;
};

// Specialised per enum: kKind (what a value is, for messages) and kEntries.
template <typename E>
struct EnumText;

template <typename E>
constexpr size_t EnumCount() {
  return std::size(EnumText<E>::kEntries);
}

// Every value, in the table's order.
template <typename E>
constexpr std::array<E, EnumCount<E>()> EnumValues() {
  std::array<E, EnumCount<E>()> values{};
  for (size_t k = 0; k < values.size(); ++k) values[k] = EnumText<E>::kEntries[k].value;
  return values;
}

template <typename E>
const char* EnumName(E value) {
  for (const EnumEntry<E>& entry : EnumText<E>::kEntries) {
    if (entry.value == value) return entry.name;
  }
  throw std::logic_error(std::string(EnumText<E>::kKind) + " value " +
                         std::to_string(static_cast<long long>(value)) + " has no name");
}

template <typename E>
std::optional<E> TryParseEnum(std::string_view text) {
  for (const EnumEntry<E>& entry : EnumText<E>::kEntries) {
    if (text == entry.name) return entry.value;
  }
  return std::nullopt;
}

// "train, val, test"
template <typename E>
std::string EnumNameList() {
  std::string list;
  for (const EnumEntry<E>& entry : EnumText<E>::kEntries) {
    if (!list.empty()) list += ", ";
    list += entry.name;
  }
  return list;
}

// Throws InputError: "unknown split 'tset' (allowed: train, val, test)".
template <typename E>
E ParseEnum(std::string_view text) {
  if (const std::optional<E> value = TryParseEnum<E>(text)) return *value;
  throw InputError("unknown " + std::string(EnumText<E>::kKind) + " '" + std::string(text) +
                   "' (allowed: " + EnumNameList<E>() + ")");
}

}  // namespace furn
