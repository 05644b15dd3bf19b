#include "nodes/formats/polycube_vtk.h"

#include "nodes/formats/surface_io.h"

#include <vector>

namespace polyhex {

void write_polycube_vtk(const std::filesystem::path& path, const RowMatrixX3d& V, const PolyCubeSegmentation& s) {
  SurfaceMesh surface{V, s.F, s.source};
  CellData data;
  std::vector<int> chart(s.chart.data(), s.chart.data() + s.chart.size());
  std::vector<int> label(s.label.data(), s.label.data() + s.label.size()), axis(label.size());
  for (size_t t = 0; t < label.size(); ++t) axis[t] = label_axis(label[t]);
  data.ints = {{"chart", chart}, {"axis", axis}, {"label", label}};
  write_surface(surface, path, data);
}

}  // namespace polyhex
