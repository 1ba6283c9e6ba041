// The vote network's training curve (issue 30): training and validation loss
// per epoch (left axis, log scale) and validation mAP@10cm (right axis), as
// a PNG drawn in-process (reports/chart.h); with a weight average also the last step's
// weights' validation mAP@10cm.
//
//   WriteTrainingCurvePng({{1, 12.0, 9.5, 0.21}, ...}, "model.vote_net.png");
#pragma once

#include <cmath>
#include <string>
#include <vector>

namespace furn {

struct TrainingCurvePoint {
  int epoch = 0;
  double train_loss = 0, validation_loss = 0;
  double validation_map = 0;  // NaN: not measured
  // With a weight average: the last step's weights' validation mAP@10cm
  // (validation_map is the average's); NaN: not measured.
  double last_weights_map = std::nan("");
};

// Throws InputError naming the file when it cannot be written.
void WriteTrainingCurvePng(const std::vector<TrainingCurvePoint>& points,
                           const std::string& title,
                           const std::string& png_path);

}  // namespace furn
