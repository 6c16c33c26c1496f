#pragma once
/// @file options.h
/// Options and results of a volume-preserving deformation.

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "vpffd/core/check.h"
#include "vpffd/core/types.h"

namespace vpffd {

/// How the volume coefficients alpha, beta, gamma (eqs. 13-18) are computed.
enum class CoefficientMethod {
  Traversal,  ///< one pass over faces and one over vertices: O(F + N), no matrix (Section 7)
  Csr,        ///< the paper's GPU formulation: alpha = B n with an N x F CSR matrix built once
};

inline CoefficientMethod parse_method(const std::string& s) {
  if (s == "traversal") return CoefficientMethod::Traversal;
  if (s == "csr") return CoefficientMethod::Csr;
  throw InvalidInputError("method: expected 'traversal' or 'csr', got '" + s + "'");
}

/// Axes as indices 0..2 from a string such as "xyz", "xy", "z" or "zx" (order kept).
/// @throws InvalidInputError for other letters or repeated axes.
inline std::vector<int> parse_axes(const std::string& s) {
  std::vector<int> axes;
  for (char c : s) {
    VPFFD_CHECK(c == 'x' || c == 'y' || c == 'z', "axes: '", s, "' has '", c, "'; use letters from \"xyz\"");
    const int a = c - 'x';
    for (int b : axes) VPFFD_CHECK(b != a, "axes: '", s, "' repeats '", c, "'");
    axes.push_back(a);
  }
  return axes;
}

/// Moves a surface point to a target (Problem 2). The source is a mesh vertex
/// (vertex >= 0) or a point given in the rest space of the lattice (vertex < 0),
/// for instance a point picked on the undeformed mesh.
struct PointConstraint {
  Index vertex = -1;
  Vector3d point = Vector3d::Zero();
  Vector3d target = Vector3d::Zero();
};

/// The most `rounds` a frame takes (backends size their per-step buffers by it).
inline constexpr int kMaxRounds = 64;

struct CorrectionOptions {
  bool preserve_volume = true;
  std::vector<int> axes{0, 1, 2};  ///< corrections along these distinct axes, in this order
  /// Cycles through `axes` this many times, each step taking an equal share of
  /// the volume still missing. 1 is the paper's method; more rounds spread the
  /// correction evenly between the axes (the paper's x-then-y order favours x),
  /// still exact, at the cost of one coefficient pass per step.
  int rounds = 1;
  VectorXd weights;                ///< empty, or one weight > 0 per control point (Remark 2)
  std::vector<std::uint8_t> fixed; ///< empty, or 1 per control point that must not move
  std::vector<PointConstraint> constraints;
  double target_volume = std::numeric_limits<double>::quiet_NaN();  ///< NaN: the rest volume
  /// With a Deformer of several parts: empty (each part keeps its rest volume), or one
  /// target volume per part. `target_volume` then must be NaN (or the mesh one part).
  std::vector<double> part_targets;
  CoefficientMethod method = CoefficientMethod::Traversal;
  int threads = 0;  ///< 0: all OpenMP threads; 1: serial
  /// Correct the volume of a mesh that is not closed. The "volume" of an open
  /// surface is that of the cone from the lattice centre and depends on it.
  bool allow_open = false;
  /// Accept a target volume that is zero or of the other sign than the rest volume
  /// (each part's, with parts): the surface is then flattened or turned inside out,
  /// which a volume-preserving edit never means by accident. Open meshes (allow_open)
  /// need not: their cone volumes may have either sign.
  bool allow_inversion = false;
  /// Fill DeformResult::timings (a clock read per pass; nothing when false).
  bool record_timings = false;
};

/// Where a frame's time went, in milliseconds (CorrectionOptions::record_timings).
/// `coefficients` are the weight + scatter passes (alpha, beta, gamma), `solves`
/// the closed-form offsets, `gathers` the offset fields at the vertices (the last
/// one fused with the volume and the reordering), `volume` any separate volume pass,
/// `reorder` the copy back to the caller's vertex order where it is not fused.
struct FrameTimings {
  bool recorded = false;
  double plan = 0, ffd = 0, coefficients = 0, solves = 0, gathers = 0, volume = 0, reorder = 0, total = 0;
};

/// What one axis step did.
struct AxisStep {
  int axis = 0;
  double volume_before = 0;  ///< volume when the step started
  double share = 0;          ///< volume the step had to add: (target - volume_before) / axes left
  double sum_squares = 0;    ///< sum of alpha^2 / weight over the free control points
  double max_offset = 0;     ///< largest |offset| of the step
};

struct DeformResult {
  RowMatrixX3d vertices;        ///< #V x 3 corrected vertices
  RowMatrixX3d control_points;  ///< N x 3 control points with the offsets applied
  RowMatrixX3d offsets;         ///< N x 3 offsets delta (zero along axes not corrected)
  double volume_before = std::numeric_limits<double>::quiet_NaN();  ///< after the plain FFD
  double volume = std::numeric_limits<double>::quiet_NaN();         ///< of the result, measured
  double target_volume = std::numeric_limits<double>::quiet_NaN();
  double constraint_error = 0;  ///< largest |D(u_s) - T| component over the constraints
  /// With a Deformer built with parts (else empty): per part, the volume after the
  /// plain FFD, the volume of the result (measured) and, when preserving, its target.
  VectorXd part_volumes_before, part_volumes, part_targets;
  std::vector<AxisStep> steps;
  FrameTimings timings;  ///< filled when CorrectionOptions::record_timings
};

}  // namespace vpffd
