#include "reports/training_curve.h"

#include <cmath>
#include <sstream>

#include "reports/run_report.h"

namespace furn {

void WriteTrainingCurvePng(const std::vector<TrainingCurvePoint>& points,
                           const std::string& title,
                           const std::string& png_path) {
  std::ostringstream script;
  script << "set terminal pngcairo noenhanced size 640,420 font 'sans,10'\n"
         << "set title '" << title << "'\nset xlabel 'epoch'\nset ylabel 'loss'\n"
         << "set logscale y\nset y2label 'validation mAP@10cm'\nset y2range [0:1]\n"
         << "set ytics nomirror\nset y2tics 0.1\nset grid\nset key top center\n"
         << "$curve << EOD\n";
  bool any_map = false, any_last = false;
  const auto value = [&script](double v) {
    if (std::isfinite(v))
      script << " " << v;
    else
      script << " NaN";
  };
  for (const TrainingCurvePoint& p : points) {
    script << p.epoch << " " << p.train_loss << " " << p.validation_loss;
    value(p.validation_map);
    value(p.last_weights_map);
    script << "\n";
    any_map |= std::isfinite(p.validation_map);
    any_last |= std::isfinite(p.last_weights_map);
  }
  script << "EOD\nplot $curve using 1:2 with linespoints pt 7 ps 0.6 title 'training loss', "
         << "$curve using 1:3 with linespoints pt 5 ps 0.6 title 'validation loss'";
  if (any_map)
    script << ", $curve using 1:4 axes x1y2 with linespoints pt 9 ps 0.8 title "
           << (any_last ? "'validation mAP@10cm (weight average)'" : "'validation mAP@10cm'");
  if (any_last)
    script << ", $curve using 1:5 axes x1y2 with linespoints pt 8 ps 0.8 dt 2 title "
              "'validation mAP@10cm (last weights)'";
  script << "\n";
  RunGnuplot(script.str(), png_path);
}

}  // namespace furn
