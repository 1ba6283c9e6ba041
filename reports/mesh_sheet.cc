#include "reports/mesh_sheet.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/imgproc.hpp>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "reports/png_file.h"

namespace furn {
namespace {

constexpr int kLabelHeight = 38;

struct ViewBasis {
  Eigen::Vector3f right, up, forward;
};

ViewBasis MakeViewBasis(double azimuth_deg, double elevation_deg) {
  const double az = azimuth_deg * M_PI / 180, el = elevation_deg * M_PI / 180;
  // Direction from the object to the viewer; azimuth 0 looks at the front (-y).
  const Eigen::Vector3f to_viewer(static_cast<float>(std::cos(el) * std::sin(az)),
                                  static_cast<float>(-std::cos(el) * std::cos(az)),
                                  static_cast<float>(std::sin(el)));
  ViewBasis basis;
  basis.forward = -to_viewer;
  basis.right = basis.forward.cross(Eigen::Vector3f::UnitZ()).normalized();
  basis.up = basis.right.cross(basis.forward);
  return basis;
}

// Painter's algorithm: far triangles first, Lambert shading on both sides.
cv::Mat RenderTile(const TriangleMesh& mesh, const MeshSheetOptions& options) {
  cv::Mat tile(options.tile_px, options.tile_px, CV_8UC3, cv::Scalar(250, 250, 250));
  if (mesh.Empty()) return tile;
  const ViewBasis view = MakeViewBasis(options.azimuth_deg, options.elevation_deg);
  std::vector<Eigen::Vector3f> projected(mesh.vertices.size());
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Eigen::Vector3f& p = mesh.vertices[i];
    projected[i] = Eigen::Vector3f(p.dot(view.right), p.dot(view.up), p.dot(view.forward));
  }
  Eigen::Vector2f low(1e30f, 1e30f), high(-1e30f, -1e30f);
  for (const Eigen::Vector3i& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      low = low.cwiseMin(projected[t[k]].head<2>());
      high = high.cwiseMax(projected[t[k]].head<2>());
    }
  }
  const float margin = 0.08f * options.tile_px;
  const float scale = (options.tile_px - 2 * margin) / std::max(1e-6f, (high - low).maxCoeff());
  const Eigen::Vector2f centre = 0.5f * (low + high);
  auto to_pixel = [&](const Eigen::Vector3f& q) {
    // cv::fillConvexPoly takes fixed-point coordinates with 4 fractional bits.
    return cv::Point(
        static_cast<int>(std::lround(16 * (options.tile_px / 2.0f + scale * (q.x() - centre.x())))),
        static_cast<int>(
            std::lround(16 * (options.tile_px / 2.0f - scale * (q.y() - centre.y())))));
  };
  std::vector<float> depth(mesh.triangles.size());
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    const Eigen::Vector3i& t = mesh.triangles[i];
    depth[i] = projected[t[0]].z() + projected[t[1]].z() + projected[t[2]].z();
  }
  std::vector<size_t> order(mesh.triangles.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(
      order.begin(), order.end(), [&](size_t a, size_t b) { return depth[a] > depth[b]; });
  const Eigen::Vector3f light = (-view.forward + 0.6f * view.up - 0.4f * view.right).normalized();
  for (size_t i : order) {
    const Eigen::Vector3i& t = mesh.triangles[i];
    const Eigen::Vector3f& a = mesh.vertices[t[0]];
    const Eigen::Vector3f normal = (mesh.vertices[t[1]] - a).cross(mesh.vertices[t[2]] - a);
    const float length = normal.norm();
    if (length <= 0) continue;
    const float shade = 0.25f + 0.75f * std::abs(normal.dot(light)) / length;
    const cv::Point corners[3] = {
        to_pixel(projected[t[0]]), to_pixel(projected[t[1]]), to_pixel(projected[t[2]])};
    const cv::Scalar colour(90 + 150 * shade, 70 + 140 * shade, 50 + 120 * shade);
    cv::fillConvexPoly(tile, corners, 3, colour, cv::LINE_AA, 4);
  }
  return tile;
}

void PutLine(cv::Mat* image, const std::string& text, cv::Point origin, double scale, int width) {
  std::string shown = text;
  int baseline = 0;
  while (shown.size() > 3 &&
         cv::getTextSize(shown, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &baseline).width > width - 6) {
    shown = shown.substr(0, shown.size() - 4) + "...";
  }
  cv::putText(*image,
              shown,
              origin,
              cv::FONT_HERSHEY_SIMPLEX,
              scale,
              cv::Scalar(30, 30, 30),
              1,
              cv::LINE_AA);
}

}  // namespace

bool MeshSheetOptions::Check() const {
  return tile_px >= 32 && tile_px <= 2048 && columns >= 1 && std::isfinite(azimuth_deg) &&
         std::isfinite(elevation_deg) && std::abs(elevation_deg) < 90;
}

void WriteMeshSheet(const std::vector<SheetTile>& tiles,
                    const MeshSheetOptions& options,
                    const std::string& png_path) {
  Require(options.Check(),
          "mesh sheet options: tile_px must be in 32..2048, columns >= 1, "
          "|elevation| < 90 degrees");
  Require(!tiles.empty(), png_path + ": no models to draw");
  Require(FileExtension(png_path) == "png", png_path + ": the sheet is written as .png");
  const int columns = std::min<int>(options.columns, static_cast<int>(tiles.size()));
  const int rows = static_cast<int>((tiles.size() + columns - 1) / columns);
  const int cell_height = options.tile_px + kLabelHeight;
  cv::Mat sheet(rows * cell_height, columns * options.tile_px, CV_8UC3, cv::Scalar(255, 255, 255));
  for (size_t i = 0; i < tiles.size(); ++i) {
    const int x = static_cast<int>(i % columns) * options.tile_px;
    const int y = static_cast<int>(i / columns) * cell_height;
    if (tiles[i].mesh != nullptr) {
      RenderTile(*tiles[i].mesh, options)
          .copyTo(sheet(cv::Rect(x, y, options.tile_px, options.tile_px)));
    }
    cv::rectangle(sheet, cv::Rect(x, y, options.tile_px, cell_height), cv::Scalar(200, 200, 200));
    PutLine(
        &sheet, tiles[i].title, cv::Point(x + 4, y + options.tile_px + 15), 0.42, options.tile_px);
    PutLine(&sheet,
            tiles[i].subtitle,
            cv::Point(x + 4, y + options.tile_px + 32),
            0.38,
            options.tile_px);
  }
  WritePngAtomically(sheet, png_path);
}

}  // namespace furn
