#include "db/split.h"

namespace furn {

Split ParseSplit(const std::string& text, const std::string& what, bool allow_all) {
  const std::optional<Split> split = TryParseEnum<Split>(text);
  if (split && (allow_all || *split != Split::kAll)) return *split;
  throw InputError(what + " '" + text + "' must be " +
                   (allow_all ? "train, val, test or all" : "train, val or test"));
}

}  // namespace furn
