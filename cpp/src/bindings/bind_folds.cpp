// Fold-over certification (header-only core vpffd/folds).

#include "common.h"
#include "vpffd/folds/certify.h"

namespace vpffd::bindings {

namespace {

template <class T>
py::array_t<T> grid_array(const std::vector<T>& v, const std::array<int, 3>& cells) {
  py::array_t<T> a({cells[0], cells[1], cells[2]});
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

}  // namespace

void bind_folds(py::module_& m) {
  m.attr("max_fold_depth") = kMaxFoldDepth;
  m.attr("max_subcells_per_cell") = kMaxSubcellsPerCell;
  m.def(
      "check_folds",
      [](const Lattice& L, RefV P, int depth, int threads) {
        FoldReport r;
        {
          py::gil_scoped_release release;
          r = check_folds(L, P, depth, threads);
        }
        std::vector<std::int8_t> status(r.status.size());
        for (size_t i = 0; i < status.size(); ++i) status[i] = static_cast<std::int8_t>(r.status[i]);
        py::dict d;
        d["cells"] = py::make_tuple(r.cells[0], r.cells[1], r.cells[2]);
        d["spans"] = r.spans;
        d["status"] = grid_array(status, r.cells);
        d["cell_min_det"] = grid_array(r.cell_min_det, r.cells);
        d["cell_lower_bound"] = grid_array(r.cell_lower_bound, r.cells);
        d["cell_subcells"] = grid_array(r.cell_subcells, r.cells);
        d["certified"] = r.certified;
        d["folded"] = r.folded;
        d["has_witness"] = r.has_witness;
        d["witness"] = r.witness;
        d["witness_param"] = r.witness_param;
        d["witness_det"] = r.witness_det;
        d["witness_cell"] = py::make_tuple(r.witness_cell[0], r.witness_cell[1], r.witness_cell[2]);
        d["min_det"] = r.min_det;
        d["lower_bound"] = r.lower_bound;
        d["n_certified"] = r.n_certified;
        d["n_folded"] = r.n_folded;
        d["n_unknown"] = r.n_unknown;
        d["n_refined"] = r.n_refined;
        d["n_subcells"] = r.n_subcells;
        d["depth"] = r.depth;
        d["seconds"] = r.seconds;
        return d;
      },
      py::arg("lattice"), py::arg("control_points"), py::arg("depth") = 3, py::arg("threads") = 0,
      "Fold-over check of a lattice: a dict with the verdict, per-cell arrays and the witness.");
}

}  // namespace vpffd::bindings
