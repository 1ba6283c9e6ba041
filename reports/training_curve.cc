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
  bool any_map = false;
  for (const TrainingCurvePoint& p : points) {
    script << p.epoch << " " << p.train_loss << " " << p.validation_loss << " ";
    if (std::isfinite(p.validation_map)) {
      script << p.validation_map << "\n";
      any_map = true;
    } else {
      script << "NaN\n";
    }
  }
  script << "EOD\nplot $curve using 1:2 with linespoints pt 7 ps 0.6 title 'training loss', "
         << "$curve using 1:3 with linespoints pt 5 ps 0.6 title 'validation loss'";
  if (any_map)
    script << ", $curve using 1:4 axes x1y2 with linespoints pt 9 ps 0.8 title "
              "'validation mAP@10cm'";
  script << "\n";
  RunGnuplot(script.str(), png_path);
}

}  // namespace furn
