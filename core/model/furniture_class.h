// The detector's object classes (the paper's four, plus optional sofa).
// Every list of classes in the project comes from this one table.
//
//   FurnitureClass c = ParseFurnitureClass("chair");   // kChair
//   std::string name = ClassName(c);                    // "chair"
//   for (FurnitureClass c : kAllClasses) ...
#pragma once

#include <array>
#include <string>

#include "core/util/enum_text.h"

namespace furn {

enum class FurnitureClass { kChair = 0, kArmchair, kTable, kSideboard, kSofa };

template <>
struct EnumText<FurnitureClass> {
  static constexpr const char* kKind = "class";
  static constexpr EnumEntry<FurnitureClass> kEntries[] = {
      {FurnitureClass::kChair, "chair"},
      {FurnitureClass::kArmchair, "armchair"},
      {FurnitureClass::kTable, "table"},
      {FurnitureClass::kSideboard, "sideboard"},
      {FurnitureClass::kSofa, "sofa"},
  };
};

inline constexpr std::array<FurnitureClass, 5> kAllClasses = EnumValues<FurnitureClass>();

// The classes evaluations report by default: the paper's four (sofa is
// reported where a dataset has sofas to find).
inline constexpr std::array<FurnitureClass, 4> kPaperClasses = {FurnitureClass::kChair,
                                                                FurnitureClass::kArmchair,
                                                                FurnitureClass::kTable,
                                                                FurnitureClass::kSideboard};

inline const char* ClassName(FurnitureClass furniture_class) { return EnumName(furniture_class); }

// Throws InputError naming `text` and the allowed names when it is not one.
inline FurnitureClass ParseFurnitureClass(const std::string& text) {
  return ParseEnum<FurnitureClass>(text);
}

// The class named `text`, or nullopt (clutter, an unknown name).
inline std::optional<FurnitureClass> FurnitureClassNamed(const std::string& text) {
  return TryParseEnum<FurnitureClass>(text);
}

}  // namespace furn
