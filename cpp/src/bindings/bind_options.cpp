// _core.CorrectionOptions: the one description of a frame's options, shared by every
// backend's deform(). A new option is a field of vpffd::CorrectionOptions and one
// property here; the keyword constructor and the repr pick it up by name.

#include <cmath>
#include <sstream>

#include "common.h"

namespace vpffd::bindings {

namespace {

std::string axes_name(const std::vector<int>& axes) {
  std::string s;
  for (int a : axes) s += char('x' + a);
  return s;
}

/// Sets every keyword as the property of that name; an unknown name is an error that
/// lists the known ones, so a misspelt option never passes silently.
void set_from_kwargs(CorrectionOptions& o, const py::kwargs& kw) {
  py::object self = py::cast(&o, py::return_value_policy::reference);
  const py::object cls = self.attr("__class__");
  const py::module_ builtins = py::module_::import("builtins");
  const py::object property = builtins.attr("property");
  auto is_option = [&](const std::string& name) {
    return !name.empty() && name[0] != '_' && py::hasattr(cls, name.c_str()) &&
           py::isinstance(cls.attr(name.c_str()), property);
  };
  for (const auto& item : kw) {
    const std::string name = py::str(item.first);
    if (!is_option(name)) {
      std::string known;
      for (const auto& k : builtins.attr("dir")(cls)) {
        const std::string s = py::str(k);
        if (is_option(s)) known += (known.empty() ? "" : ", ") + s;
      }
      throw InvalidInputError("CorrectionOptions: no option '" + name + "' (options: " + known + ")");
    }
    try {
      self.attr(name.c_str()) = item.second;
    } catch (py::error_already_set& e) {
      if (!e.matches(PyExc_TypeError)) throw;
      std::string shown = py::repr(item.second);
      if (shown.size() > 60) shown = shown.substr(0, 57) + "...";
      throw py::type_error("CorrectionOptions: option '" + name + "' cannot take " + shown + " (" +
                           std::string(py::str(py::type::of(item.second).attr("__name__"))) + ")");
    }
  }
}

}  // namespace

void bind_options(py::module_& m) {
  py::class_<CorrectionOptions>(m, "CorrectionOptions",
                                "The options of one frame, for every backend's deform() (vpffd::CorrectionOptions). "
                                "Build with keywords: CorrectionOptions(axes='xy', rounds=3, ...).")
      .def(py::init([](const py::kwargs& kw) {
        CorrectionOptions o;
        set_from_kwargs(o, kw);
        return o;
      }))
      .def_readwrite("preserve_volume", &CorrectionOptions::preserve_volume,
                     "Correct the volume to target_volume (False: plain FFD plus any constraints).")
      .def_property(
          "axes", [](const CorrectionOptions& o) { return axes_name(o.axes); },
          [](CorrectionOptions& o, const std::string& s) { o.axes = parse_axes(s); },
          "Axes the control points move along, in order: 'xyz', 'xy', 'z', ...")
      .def_property(
          "rounds", [](const CorrectionOptions& o) { return o.rounds; },
          [](CorrectionOptions& o, long long r) {
            // The range itself is the frame's check (Deformer::plan); here only what fits an int.
            VPFFD_CHECK(r >= 0 && r <= 1000000, "deform: rounds is ", r, "; expected 1..", kMaxRounds);
            o.rounds = static_cast<int>(r);
          },
          "Cycles through the axes (1..64).")
      .def_property(
          "weights",
          [](const CorrectionOptions& o) -> std::optional<VectorXd> {
            if (o.weights.size() == 0) return std::nullopt;
            return o.weights;
          },
          [](CorrectionOptions& o, std::optional<VectorXd> w) { o.weights = w ? std::move(*w) : VectorXd(); },
          "None, or one weight > 0 per control point (N,).")
      .def_property(
          "fixed",
          [](const CorrectionOptions& o) -> std::optional<std::vector<std::uint8_t>> {
            if (o.fixed.empty()) return std::nullopt;
            return o.fixed;
          },
          [](CorrectionOptions& o, std::optional<std::vector<std::uint8_t>> f) {
            o.fixed = f ? std::move(*f) : std::vector<std::uint8_t>{};
          },
          "None, or 1 per control point that must not move (N,).")
      .def_property(
          "constraints",
          [](const CorrectionOptions& o) {
            PyConstraints out;
            for (const PointConstraint& c : o.constraints) out.emplace_back(c.vertex, c.point, c.target);
            return out;
          },
          [](CorrectionOptions& o, const PyConstraints& cs) {
            o.constraints.clear();
            for (const auto& [v, p, t] : cs) o.constraints.push_back({v, p, t});
          },
          "Point constraints as (vertex, point, target): vertex >= 0 names a mesh vertex, -1 takes the rest-space "
          "point; target is where it must go (world units).")
      .def_property(
          "target_volume",
          [](const CorrectionOptions& o) -> std::optional<double> {
            if (std::isnan(o.target_volume)) return std::nullopt;
            return o.target_volume;
          },
          [](CorrectionOptions& o, std::optional<double> v) {
            o.target_volume = v ? *v : std::numeric_limits<double>::quiet_NaN();
          },
          "None (the rest volume) or the volume to keep, world units cubed.")
      .def_property(
          "part_targets",
          [](const CorrectionOptions& o) -> std::optional<std::vector<double>> {
            if (o.part_targets.empty()) return std::nullopt;
            return o.part_targets;
          },
          [](CorrectionOptions& o, std::optional<std::vector<double>> t) {
            o.part_targets = t ? std::move(*t) : std::vector<double>{};
          },
          "None (each part keeps its rest volume) or one target volume per part.")
      .def_property(
          "method",
          [](const CorrectionOptions& o) {
            return std::string(o.method == CoefficientMethod::Csr ? "csr" : "traversal");
          },
          [](CorrectionOptions& o, const std::string& s) { o.method = parse_method(s); },
          "How the volume coefficients are computed: 'traversal' or 'csr'.")
      .def_readwrite("threads", &CorrectionOptions::threads, "0: all OpenMP threads; 1: serial.")
      .def_readwrite("allow_open", &CorrectionOptions::allow_open,
                     "Correct the cone volume of a mesh that is not closed.")
      .def_readwrite("allow_inversion", &CorrectionOptions::allow_inversion,
                     "Accept a target volume of zero or of the other sign than the rest volume (the surface "
                     "is flattened or turned inside out).")
      .def_readwrite("record_timings", &CorrectionOptions::record_timings,
                     "Add 'timings' (ms per pass) to the result (CPU backends).")
      .def("__repr__", [](const CorrectionOptions& o) {
        std::ostringstream s;
        s << "CorrectionOptions(preserve_volume=" << (o.preserve_volume ? "True" : "False") << ", axes='"
          << axes_name(o.axes) << "', rounds=" << o.rounds << ", method='"
          << (o.method == CoefficientMethod::Csr ? "csr" : "traversal") << "', constraints=" << o.constraints.size();
        if (o.weights.size()) s << ", weights=(" << o.weights.size() << ",)";
        if (!o.fixed.empty()) s << ", fixed=(" << o.fixed.size() << ",)";
        if (!std::isnan(o.target_volume)) s << ", target_volume=" << o.target_volume;
        if (!o.part_targets.empty()) s << ", part_targets=(" << o.part_targets.size() << ",)";
        s << ", threads=" << o.threads << (o.allow_open ? ", allow_open=True" : "")
          << (o.allow_inversion ? ", allow_inversion=True" : "")
          << (o.record_timings ? ", record_timings=True" : "") << ")";
        return s.str();
      });
}

}  // namespace vpffd::bindings
