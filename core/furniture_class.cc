#include "core/furniture_class.h"

#include "core/error.h"

namespace furn {

const char* ClassName(FurnitureClass furniture_class) {
  switch (furniture_class) {
    case FurnitureClass::kChair:
      return "chair";
    case FurnitureClass::kArmchair:
      return "armchair";
    case FurnitureClass::kTable:
      return "table";
    case FurnitureClass::kSideboard:
      return "sideboard";
    case FurnitureClass::kSofa:
      return "sofa";
  }
  return "unknown";
}

FurnitureClass ParseFurnitureClass(const std::string& text) {
  for (FurnitureClass c : kAllClasses) {
    if (text == ClassName(c)) return c;
  }
  throw InputError("unknown class '" + text +
                   "' (allowed: chair, armchair, table, sideboard, sofa)");
}

}  // namespace furn
