#include "reports/training_curve.h"

#include <cmath>

#include "reports/chart.h"

namespace furn {

void WriteTrainingCurvePng(const std::vector<TrainingCurvePoint>& points,
                           const std::string& title,
                           const std::string& png_path) {
  Chart chart;
  chart.title = title;
  chart.x.label = "epoch";
  chart.y.label = "loss";
  chart.y.log = true;
  chart.with_y2 = true;
  chart.y2 = MakeAxis("validation mAP@10cm", 0, 1);
  chart.y2.tick_step = 0.1;
  chart.legend = LegendPlace::kTopRight;
  ChartSeries train = MakeSeries("training loss", ChartStyle::kLinesPoints, ChartPalette(0));
  ChartSeries validation = MakeSeries("validation loss", ChartStyle::kLinesPoints, ChartPalette(1));
  ChartSeries map = MakeSeries("validation mAP@10cm", ChartStyle::kLinesPoints, ChartPalette(2));
  ChartSeries last =
      MakeSeries("validation mAP@10cm (last weights)", ChartStyle::kDashedLines, ChartPalette(3));
  map.right_axis = last.right_axis = true;
  bool any_map = false, any_last = false;
  for (const TrainingCurvePoint& p : points) {
    for (ChartSeries* s : {&train, &validation, &map, &last}) s->x.push_back(p.epoch);
    train.y.push_back(p.train_loss);
    validation.y.push_back(p.validation_loss);
    map.y.push_back(p.validation_map);
    last.y.push_back(p.last_weights_map);
    any_map |= std::isfinite(p.validation_map);
    any_last |= std::isfinite(p.last_weights_map);
  }
  chart.series = {train, validation};
  if (any_last) map.title = "validation mAP@10cm (weight average)";
  if (any_map) chart.series.push_back(map);
  if (any_last) chart.series.push_back(last);
  WriteChartPng(chart, png_path);
}

}  // namespace furn
