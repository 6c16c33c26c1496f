// Lattice structure, knots, basis functions and the plain FFD of points.

#include "common.h"
#include "vpffd/bspline/basis.h"
#include "vpffd/bspline/knots.h"
#include "vpffd/ffd/basis_matrix.h"
#include "vpffd/ffd/points.h"
#include "vpffd/lattice/embed.h"
#include "vpffd/lattice/lattice.h"
#include "vpffd/lattice/periodic.h"

namespace vpffd::bindings {

namespace {

Seam parse_seam(const std::string& s) {
  if (s == "none") return Seam::None;
  if (s == "shift") return Seam::Shift;
  if (s == "closed") return Seam::Closed;
  if (s == "twist") return Seam::Twist;
  throw InvalidInputError("seam: expected 'none', 'shift', 'closed' or 'twist', got '" + s + "'");
}

const char* seam_name(Seam s) {
  switch (s) {
    case Seam::Shift: return "shift";
    case Seam::Closed: return "closed";
    case Seam::Twist: return "twist";
    default: return "none";
  }
}

}  // namespace

void bind_lattice(py::module_& m) {
  py::class_<Lattice>(m, "LatticeSpec", "Structure of a B-spline lattice: degrees, knots, world box.")
      .def(py::init([](std::array<int, 3> degree, std::array<std::vector<double>, 3> knots, Vector3d box_min,
                       Vector3d box_max, std::array<std::string, 3> seams) {
             Lattice L;
             L.degree = degree;
             L.knots = std::move(knots);
             L.box_min = box_min;
             L.box_max = box_max;
             for (int a = 0; a < 3; ++a) L.seam[a] = parse_seam(seams[a]);
             validate_lattice(L);
             return L;
           }),
           py::arg("degree"), py::arg("knots"), py::arg("box_min"), py::arg("box_max"),
           py::arg("seams") = std::array<std::string, 3>{"none", "none", "none"})
      .def_property_readonly("seams",
                             [](const Lattice& L) {
                               return std::array<std::string, 3>{seam_name(L.seam[0]), seam_name(L.seam[1]),
                                                                 seam_name(L.seam[2])};
                             })
      .def_property_readonly("distinct_shape",
                             [](const Lattice& L) {
                               return std::array<int, 3>{L.distinct_dim(0), L.distinct_dim(1), L.distinct_dim(2)};
                             })
      .def(
          "expand_control_points",
          [](const Lattice& L, RefV P) {
            const Ties t = make_ties(L);
            VPFFD_CHECK(P.rows() == t.n_distinct, "expand_control_points: ", P.rows(),
                        " control points, the lattice has ", t.n_distinct, " distinct ones");
            return expand_points(t, P);
          },
          py::arg("control_points"), "(N_ext, 3) extended control points of (N, 3) distinct ones (periodic.h).")
      .def(
          "tie_sources",
          [](const Lattice& L) {
            const Ties t = make_ties(L);
            if (!t.identity) return t.source;
            std::vector<std::int32_t> id(static_cast<size_t>(t.n_distinct));
            for (size_t i = 0; i < id.size(); ++i) id[i] = static_cast<std::int32_t>(i);
            return id;
          },
          "Per extended control point, the distinct one it copies.")
      .def(
          "wrap_points",
          [](const Lattice& L, RefV X) {
            RowMatrixX3d W(X.rows(), 3);
            std::vector<std::uint8_t> mirrored(static_cast<size_t>(X.rows()));
            for (Index r = 0; r < X.rows(); ++r) {
              bool f = false;
              W.row(r) = wrap_point(L, X.row(r).transpose(), &f).transpose();
              mirrored[r] = f;
            }
            return py::make_tuple(W, mirrored);
          },
          py::arg("points"), "(points wrapped into the box along periodic axes, mirrored flags).")
      .def_readonly("degree", &Lattice::degree)
      .def_readonly("knots", &Lattice::knots)
      .def_readonly("box_min", &Lattice::box_min)
      .def_readonly("box_max", &Lattice::box_max)
      .def_property_readonly("shape", &Lattice::dims)
      .def("rest_control_points", &rest_control_points, "(N, 3) control points at the Greville abscissae.")
      .def(
          "parameters",
          [](const Lattice& L, RefV X) {
            RowMatrixX3d U(X.rows(), 3);
            for (Index r = 0; r < X.rows(); ++r) U.row(r) = parameter_of(L, X.row(r).transpose()).transpose();
            return U;
          },
          py::arg("points"), "(n, 3) parameters (u, v, w) of world points.");

  m.def("clamped_uniform_knots", &clamped_uniform_knots, py::arg("n"), py::arg("degree"), py::arg("lo") = 0.0,
        py::arg("hi") = 1.0);
  m.def("periodic_uniform_knots", &periodic_uniform_knots, py::arg("n"), py::arg("degree"), py::arg("lo") = 0.0,
        py::arg("hi") = 1.0);
  m.def("greville", [](const std::vector<double>& t, int n, int d) { return greville(t, n, d); });
  m.def(
      "basis_functions",
      [](const std::vector<double>& t, int degree, const std::vector<double>& u, bool derivatives) {
        // All n basis functions at each u (dense (len(u), n)), from Cox-de Boor: the reference.
        const int n = static_cast<int>(t.size()) - degree - 1;
        validate_knots(t, n, degree, 'u');
        RowMatrixXd B = RowMatrixXd::Zero(u.size(), n);
        double N[kMaxDegree + 1], dN[kMaxDegree + 1];
        for (size_t q = 0; q < u.size(); ++q) {
          VPFFD_CHECK(std::isfinite(u[q]), "basis_functions: u[", q, "] is not finite");
          const int s = find_span(t, n, degree, u[q]);
          basis_values_derivs(t, degree, s, u[q], N, dN);
          for (int r = 0; r <= degree; ++r) B(q, s - degree + r) = derivatives ? dN[r] : N[r];
        }
        return B;
      },
      py::arg("knots"), py::arg("degree"), py::arg("u"), py::arg("derivatives") = false,
      "Dense (len(u), n) matrix of B-spline basis values (or first derivatives) by Cox-de Boor.");
  m.def(
      "basis_functions_fast",
      [](const std::vector<double>& t, int degree, const std::vector<double>& u) {
        // The per-span power form the kernels use, for comparison with basis_functions.
        const int n = static_cast<int>(t.size()) - degree - 1;
        validate_knots(t, n, degree, 'u');
        const SpanPolynomials sp = span_polynomials(t, n, degree);
        RowMatrixXd B = RowMatrixXd::Zero(u.size(), n);
        double N[kMaxDegree + 1];
        for (size_t q = 0; q < u.size(); ++q) {
          VPFFD_CHECK(std::isfinite(u[q]), "basis_functions_fast: u[", q, "] is not finite");
          const int s = find_span(t, n, degree, u[q]);
          const double tau = (u[q] - t[s]) * sp.inv_width[s - degree];
          eval_span(sp.span_coef(s), degree + 1, tau, N);
          for (int r = 0; r <= degree; ++r) B(q, s - degree + r) = N[r];
        }
        return B;
      },
      py::arg("knots"), py::arg("degree"), py::arg("u"));
  m.def(
      "point_basis_matrix",
      [](const Lattice& L, RefV X, const std::string& outside) {
        const OutsidePolicy pol = parse_outside_policy(outside);
        CsrMatrix A;
        {
          py::gil_scoped_release release;
          validate_lattice(L);
          A = vertex_basis_matrix(basis_tables(L), embed(L, X, pol, 0, "point"));
        }
        return csr_to_python(std::move(A));
      },
      py::arg("lattice"), py::arg("points"), py::arg("outside") = "error");
  m.def(
      "ffd_points",
      [](const Lattice& L, RefV P, RefV X, const std::string& outside, int threads, const py::object& out) {
        const OutsidePolicy pol = parse_outside_policy(outside);
        double* into = out_rows(out, X.rows(), "deform_points");
        RowMatrixX3d Y;
        {
          py::gil_scoped_release release;
          Y = ffd_points(L, P, X, pol, threads, into);
        }
        return into ? out : py::cast(std::move(Y));
      },
      py::arg("lattice"), py::arg("control_points"), py::arg("points"), py::arg("outside") = "error",
      py::arg("threads") = 0, py::arg("out") = py::none());
}

}  // namespace vpffd::bindings
