// Command lines the workbench tests share.
#pragma once

namespace furn::testing {

// A small codebook model of the procedural:4 catalog (k-means, 20 words, 8
// azimuths; seconds to train): append the model file's path.
inline constexpr const char* kTrainSmallCodebook =
    "train --no-vote-net --catalog procedural:4 --vocab kmeans --words 20 --azimuths 8 --quiet "
    "--out ";

}  // namespace furn::testing
