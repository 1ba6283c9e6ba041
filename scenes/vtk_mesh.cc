#include "scenes/vtk_mesh.h"

#include <vtkCellArray.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkObject.h>
#include <vtkPolyData.h>
#include <vtkPolyDataReader.h>
#include <vtkTriangleFilter.h>

#include <cmath>
#include <cstdlib>
#include <sstream>
#include <vector>

#include "core/util/error.h"
#include "core/util/file_util.h"

namespace furn {

namespace {

constexpr size_t kMaxToken = 64;  // VTK reads words into fixed buffers

// The words of a legacy file after its three header lines, read one at a
// time; every count is checked against what the rest of the file can hold.
class VtkWords {
 public:
  VtkWords(std::istream& lines, const std::string& path) : path_(path) {
    for (std::string word; lines >> word;) {
      Require(word.size() <= kMaxToken,
              path + ": a word of " + std::to_string(word.size()) + " characters (at most " +
                  std::to_string(kMaxToken) + ")");
      words_.push_back(std::move(word));
    }
  }
  bool done() const { return at_ >= words_.size(); }
  size_t left() const { return words_.size() - at_; }
  size_t position() const { return at_; }
  // The next word, or "" at the end.
  const std::string& peek() const { return done() ? empty_ : words_[at_]; }
  const std::string& Next(const char* what) {
    Require(!done(), path_ + ": the file ends where " + std::string(what) + " is due");
    return words_[at_++];
  }
  // The next word as a count of at most `most`.
  uint64_t Count(const char* what, uint64_t most) {
    const std::string& word = Next(what);
    Require(!word.empty() && word.size() <= 18 &&
                word.find_first_not_of("0123456789") == std::string::npos,
            path_ + ": " + what + " '" + word + "' is not a count");
    const uint64_t value = std::stoull(word);
    Require(value <= most, path_ + ": " + what + " " + word + " is more than the file can hold");
    return value;
  }

 private:
  const std::string& path_;
  const std::string empty_;
  std::vector<std::string> words_;
  size_t at_ = 0;
};

// The three header lines: the magic, a title, ASCII.
void CheckVtkHeader(std::istream& lines, const std::string& path) {
  std::string line;
  std::getline(lines, line);
  Require(line.rfind("# vtk DataFile", 0) == 0,
          path + ": not a VTK legacy file (it must start with \"# vtk DataFile\")");
  std::getline(lines, line);  // title
  std::getline(lines, line);
  if (!line.empty() && line.back() == '\r') line.pop_back();
  Require(line == "ASCII",
          path + ": only ASCII VTK legacy files are read (this one says '" + line.substr(0, 20) +
              "'); convert it to ASCII, PLY or OBJ");
}

// A POINTS section (after its keyword), copied to `out` as doubles; returns
// the point count.
uint64_t CopyPoints(VtkWords& words, const std::string& path, std::ostream& out) {
  const uint64_t points = words.Count("the POINTS count", words.left() / 3);
  const std::string type = words.Next("the POINTS type");
  Require(type == "float" || type == "double",
          path + ": POINTS of type '" + type + "' (float or double are read)");
  out << "POINTS " << points << " double\n";
  for (uint64_t i = 0; i < 3 * points; ++i) {
    const std::string& word = words.Next("a coordinate");
    char* end = nullptr;
    const double value = std::strtod(word.c_str(), &end);
    Require(end == word.c_str() + word.size() && std::isfinite(value),
            path + ": coordinate '" + word + "' is not a finite number");
    out << word << (i % 3 == 2 ? '\n' : ' ');
  }
  return points;
}

// A cell section (after its keyword) over `points` points, checked cell by
// cell; copied to `out` for polygons and strips (lines and vertices hold no
// triangles).
void CopyCells(VtkWords& words,
               const std::string& section,
               uint64_t points,
               const std::string& path,
               std::ostream& out) {
  const uint64_t cells = words.Count("a cell count", words.left());
  const uint64_t size = words.Count("a cell list size", words.left());
  Require(size <= words.left(), path + ": " + section + " runs past the end of the file");
  Require(size >= cells,
          path + ": " + section + " declares " + std::to_string(cells) + " cells in " +
              std::to_string(size) + " numbers");
  Require(words.peek() != "OFFSETS",
          path +
              ": the VTK 5 cell layout (OFFSETS, CONNECTIVITY) is not read; write the "
              "file as legacy version 4.2, PLY or OBJ");
  const size_t end = words.position() + size;
  std::ostringstream cell_text;
  for (uint64_t c = 0; c < cells; ++c) {
    Require(words.position() < end, path + ": " + section + " runs past its declared size");
    const uint64_t corners = words.Count("a cell's corner count", end - words.position() - 1);
    Require(corners == 0 || points > 0, path + ": a cell names points, but POINTS is empty");
    cell_text << corners;
    for (uint64_t k = 0; k < corners; ++k) {
      cell_text << ' ' << words.Count("a point index", points == 0 ? 0 : points - 1);
    }
    cell_text << '\n';
  }
  Require(words.position() == end,
          path + ": " + section + " holds " + std::to_string(size) +
              " numbers, its cells another count");
  if (section == "POLYGONS" || section == "TRIANGLE_STRIPS")
    out << section << ' ' << cells << ' ' << size << '\n' << cell_text.str();
}

// The text of an ASCII legacy polydata file checked section by section and
// cut down to its geometry (POINTS and the cell sections, in the classic
// layout "n size" followed by n groups "k i1 .. ik"): VTK's legacy reader
// trusts declared counts and word lengths (a long word or a count beyond the
// file crashed it under fuzzing), so nothing reaches it unchecked. Point and
// cell data (normals, texture coordinates, ...) are dropped: a model is its
// triangles. Throws InputError naming the file and the rule.
std::string CheckedGeometry(const std::string& bytes, const std::string& path) {
  std::istringstream lines(bytes);
  CheckVtkHeader(lines, path);
  VtkWords words(lines, path);
  Require(words.Next("DATASET") == "DATASET" && words.Next("POLYDATA") == "POLYDATA",
          path + ": not VTK polydata (DATASET POLYDATA is needed for a mesh)");
  std::ostringstream out;
  out << "# vtk DataFile Version 3.0\nchecked\nASCII\nDATASET POLYDATA\n";
  uint64_t points = 0;
  bool have_points = false;
  while (!words.done()) {
    const std::string section = words.Next("a section");
    if (section == "POINT_DATA" || section == "CELL_DATA" || section == "FIELD" ||
        section == "METADATA") {
      break;  // attributes follow: not needed for the triangles
    }
    if (section == "POINTS") {
      Require(!have_points, path + ": two POINTS sections");
      points = CopyPoints(words, path, out);
      have_points = true;
      continue;
    }
    Require(section == "POLYGONS" || section == "TRIANGLE_STRIPS" || section == "LINES" ||
                section == "VERTICES",
            path + ": unknown section '" + section +
                "' (POINTS, POLYGONS, TRIANGLE_STRIPS, LINES, VERTICES, POINT_DATA, "
                "CELL_DATA)");
    Require(have_points, path + ": " + section + " before POINTS");
    CopyCells(words, section, points, path, out);
  }
  Require(have_points, path + ": no POINTS section");
  return out.str();
}

}  // namespace

TriangleMesh ReadVtkPolyData(const std::string& path) {
  const std::string checked = CheckedGeometry(ReadFileBytes(path), path);
  // VTK's own reader, from the checked text (PCL's loadPolygonFileVTK keeps
  // polygons only and drops triangle strips, which the paper's models are
  // made of); the triangle filter turns polygons and strips into triangles.
  // VTK's own complaints are ours to say, in one line.
  vtkObject::GlobalWarningDisplayOff();
  vtkNew<vtkPolyDataReader> reader;
  reader->ReadFromInputStringOn();
  reader->SetInputString(checked);
  vtkNew<vtkTriangleFilter> triangles;
  triangles->SetInputConnection(reader->GetOutputPort());
  triangles->PassLinesOff();
  triangles->PassVertsOff();
  triangles->Update();
  vtkPolyData* data = triangles->GetOutput();
  Require(data != nullptr && data->GetPoints() != nullptr && data->GetNumberOfPolys() > 0,
          path + ": mesh has no faces (a model needs at least one triangle)");
  TriangleMesh mesh;
  const vtkIdType count = data->GetNumberOfPoints();
  mesh.vertices.reserve(static_cast<size_t>(count));
  for (vtkIdType i = 0; i < count; ++i) {
    double p[3];
    data->GetPoint(i, p);
    Require(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]),
            path + ": a point is not a finite number");
    mesh.vertices.emplace_back(
        static_cast<float>(p[0]), static_cast<float>(p[1]), static_cast<float>(p[2]));
  }
  vtkCellArray* polys = data->GetPolys();
  vtkNew<vtkIdList> corners;
  for (polys->InitTraversal(); polys->GetNextCell(corners);) {
    if (corners->GetNumberOfIds() != 3) continue;
    for (vtkIdType k = 0; k < 3; ++k)
      Require(corners->GetId(k) >= 0 && corners->GetId(k) < count,
              path + ": a polygon names a point that does not exist");
    mesh.triangles.emplace_back(static_cast<int>(corners->GetId(0)),
                                static_cast<int>(corners->GetId(1)),
                                static_cast<int>(corners->GetId(2)));
  }
  Require(!mesh.triangles.empty(),
          path + ": mesh has no faces (a model needs at least one triangle)");
  return mesh;
}

}  // namespace furn
