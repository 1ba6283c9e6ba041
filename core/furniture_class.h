// The detector's object classes (the paper's four, plus optional sofa).
//
//   FurnitureClass c = ParseFurnitureClass("chair");   // kChair
//   std::string name = ClassName(c);                    // "chair"
#pragma once

#include <array>
#include <string>

namespace furn {

enum class FurnitureClass { kChair = 0, kArmchair, kTable, kSideboard, kSofa };

inline constexpr std::array<FurnitureClass, 5> kAllClasses = {FurnitureClass::kChair,
                                                              FurnitureClass::kArmchair,
                                                              FurnitureClass::kTable,
                                                              FurnitureClass::kSideboard,
                                                              FurnitureClass::kSofa};

const char* ClassName(FurnitureClass furniture_class);

// Throws InputError naming `text` and the allowed names when it is not one.
FurnitureClass ParseFurnitureClass(const std::string& text);

}  // namespace furn
