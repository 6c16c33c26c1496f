// Times one volume-preserving frame (twist 90 deg + squash 0.6, 10^3 cubic
// lattice, xyz correction) on an icosphere of the given subdivision level or a
// binary little-endian triangle PLY, on 1 thread, on all threads and, when the
// Vulkan backend is built and a device is found, on the GPU.
//
//   bench_frame [icosphere LEVEL | PLY_FILE] [REPEATS]
//   bench_frame --frames N [icosphere LEVEL | PLY_FILE]
//   bench_frame --moves N [icosphere LEVEL | PLY_FILE]
//
// Prints one line per backend: median milliseconds of the plain FFD and the xyz
// frame, the volume error and, on Vulkan, the GPU time from timestamp queries; on the
// CPU also the frame's passes (FFD, coefficient passes, solves, gathers, the copy to
// the caller's order), medians of the frame's own clocks, and the cost of moving the
// rest mesh (set_rest_vertices).
//
// With --frames N it times nothing: it builds the Deformer and runs N xyz frames on
// one thread, for counts under valgrind's cachegrind (instructions, simulated cache
// misses), which a noisy machine does not change (bench/cachegrind_frame.sh); with
// --moves N, N moves of the rest mesh instead (as the timed move below).

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "vpffd/vpffd.h"
#ifdef VPFFD_HAS_VULKAN
#include "vpffd/backend/vulkan.h"
#endif

namespace {

vpffd::TriMesh read_ply(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + path);
  std::string line;
  long nv = -1, nf = -1;
  while (std::getline(in, line) && line != "end_header") {
    if (line.rfind("element vertex", 0) == 0) nv = std::stol(line.substr(15));
    if (line.rfind("element face", 0) == 0) nf = std::stol(line.substr(13));
    if (line.rfind("format", 0) == 0 && line.find("binary_little_endian") == std::string::npos)
      throw std::runtime_error(path + ": only binary little-endian PLY (float xyz, uchar-int faces)");
  }
  if (nv <= 0 || nf <= 0) throw std::runtime_error(path + ": no vertices or faces");
  vpffd::TriMesh m;
  m.V.resize(nv, 3);
  std::vector<float> xyz(3 * nv);
  in.read(reinterpret_cast<char*>(xyz.data()), 12 * nv);
  for (long i = 0; i < 3 * nv; ++i) m.V.data()[i] = xyz[i];
  m.F.resize(nf, 3);
  for (long f = 0; f < nf; ++f) {
    unsigned char n = 0;
    in.read(reinterpret_cast<char*>(&n), 1);
    if (n != 3) throw std::runtime_error(path + ": not a triangle mesh");
    in.read(reinterpret_cast<char*>(&m.F(f, 0)), 12);
  }
  if (!in) throw std::runtime_error(path + ": truncated");
  return m;
}

double median_ms(const std::function<void()>& f, int repeats) {
  f();  // warm-up
  std::vector<double> t;
  for (int r = 0; r < repeats; ++r) {
    const auto a = std::chrono::steady_clock::now();
    f();
    t.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - a).count());
  }
  std::nth_element(t.begin(), t.begin() + t.size() / 2, t.end());
  return t[t.size() / 2];
}

/// V moved by s of the mesh's size along x and s / 2 along y.
vpffd::RowMatrixX3d moved(const vpffd::RowMatrixX3d& V, const vpffd::Vector3d& lo, const vpffd::Vector3d& hi,
                          double s) {
  vpffd::RowMatrixX3d X = V;
  X.col(0).array() += s * (hi[0] - lo[0]);
  X.col(1).array() += 0.5 * s * (hi[1] - lo[1]);
  return X;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    int count_frames = -1;  // --frames N / --moves N: run N frames or moves untimed
    bool count_moves = false;
    if (argc > 2 && (std::strcmp(argv[1], "--frames") == 0 || std::strcmp(argv[1], "--moves") == 0)) {
      count_moves = std::strcmp(argv[1], "--moves") == 0;
      count_frames = std::max(0, std::atoi(argv[2]));
      argv += 2;
      argc -= 2;
    }
    std::string what = argc > 1 ? argv[1] : "icosphere";
    vpffd::TriMesh m;
    if (what == "icosphere") {
      m = vpffd::icosphere(argc > 2 ? std::atoi(argv[2]) : 7);
      argv += 1;
      argc -= 1;
    } else {
      m = read_ply(what);
    }
    const int repeats = argc > 2 ? std::max(1, std::atoi(argv[2])) : 9;
    const vpffd::Vector3d lo = m.V.colwise().minCoeff().transpose(), hi = m.V.colwise().maxCoeff().transpose();
    const vpffd::Vector3d pad = 0.05 * (hi - lo), c = 0.5 * (lo + hi);
    const vpffd::Lattice L = vpffd::make_lattice(lo - pad, hi + pad, {10, 10, 10}, {3, 3, 3});
    const vpffd::RowMatrixX3d P =
        vpffd::twist(vpffd::scale(vpffd::rest_control_points(L), {1, 1, 0.6}, c), 0.5 * M_PI, 2, c);
    if (count_frames >= 0 && count_moves) {
      vpffd::Deformer d(m.V, m.F, L, vpffd::OutsidePolicy::Error, 1);
      const vpffd::RowMatrixX3d X[2] = {moved(m.V, lo, hi, 0.01), moved(m.V, lo, hi, -0.01)};
      for (int k = 0; k < count_frames; ++k) d.set_rest_vertices(X[k % 2], 1);
      std::printf("mesh %s: %ld vertices; %d moves of the rest mesh on 1 thread\n", what.c_str(), long(m.V.rows()),
                  count_frames);
      return 0;
    }
    if (count_frames >= 0) {
      vpffd::Deformer d(m.V, m.F, L, vpffd::OutsidePolicy::Error, 1);
      vpffd::CorrectionOptions o;
      o.threads = 1;
      double err = 0;
      for (int f = 0; f < count_frames; ++f) {
        const vpffd::DeformResult r = d.deform(P, o);
        err = std::max(err, std::abs(r.volume - r.target_volume) / r.target_volume);
      }
      std::printf("mesh %s: %ld vertices; %d xyz frames on 1 thread, volume error %.1e\n", what.c_str(),
                  long(m.V.rows()), count_frames, err);
      return 0;
    }
    std::printf("mesh %s: %ld vertices, %ld faces; lattice 10x10x10 cubic; median of %d\n", what.c_str(),
                long(m.V.rows()), long(m.F.rows()), repeats);
    std::printf("%-28s %10s %12s %12s %12s\n", "backend", "FFD ms", "xyz ms", "GPU xyz ms", "volume err");

    vpffd::Deformer d(m.V, m.F, L);
    for (int threads : {1, 0}) {
      vpffd::CorrectionOptions o;
      o.threads = threads;
      vpffd::DeformResult r;
      const double t_ffd = median_ms([&] { d.ffd(P, threads); }, repeats);
      const double t_xyz = median_ms([&] { r = d.deform(P, o); }, repeats);
      std::printf("%-28s %10.3f %12.3f %12s %12.1e\n",
                  (std::string("cpu, ") + std::to_string(vpffd::resolve_threads(threads)) + " thread(s)").c_str(),
                  t_ffd, t_xyz, "", std::abs(r.volume - r.target_volume) / r.target_volume);
      // Where the frame goes, by its own clocks (medians): the rows an A/B of two
      // builds compares (bench/README.md).
      o.record_timings = true;
      std::vector<double> pass[5];
      for (int k = 0; k < repeats; ++k) {
        const vpffd::FrameTimings tm = d.deform(P, o).timings;
        const double v[5] = {tm.ffd, tm.coefficients, tm.solves, tm.gathers, tm.reorder};
        for (int p = 0; p < 5; ++p) pass[p].push_back(v[p]);
      }
      for (auto& p : pass) std::nth_element(p.begin(), p.begin() + p.size() / 2, p.end());
      std::printf("  passes ms: ffd %.3f  coefficients %.3f  solves %.3f  gathers %.3f  reorder %.3f\n",
                  pass[0][repeats / 2], pass[1][repeats / 2], pass[2][repeats / 2], pass[3][repeats / 2],
                  pass[4][repeats / 2]);
      // Moving the rest mesh (set_rest_vertices, issue 13), on a Deformer of its own:
      // back and forth between two positions 2 % of the mesh's size apart (inside the
      // lattice's padding), so that vertices change cell every call and the processing
      // order, faces and fans are carried over to a new order each time.
      vpffd::Deformer dm(m.V, m.F, L, vpffd::OutsidePolicy::Error, threads);
      const vpffd::RowMatrixX3d X[2] = {moved(m.V, lo, hi, 0.01), moved(m.V, lo, hi, -0.01)};
      int step = 0;
      const double t_move = median_ms([&] { dm.set_rest_vertices(X[step++ % 2], threads); }, repeats);
      std::printf("  move rest mesh ms: %.3f (set_rest_vertices, the cell order changing every call)\n", t_move);
    }
#ifdef VPFFD_HAS_VULKAN
    std::string why;
    for (const auto& dev : vpffd::vulkan::devices(&why)) {
      if (!dev.suitable) continue;
      for (auto prec : {vpffd::vulkan::Precision::Float64, vpffd::vulkan::Precision::FloatFloat}) {
        if (prec == vpffd::vulkan::Precision::Float64 && !dev.float64) continue;
        vpffd::vulkan::VulkanDeformer g(m.V, m.F, L, vpffd::OutsidePolicy::Error, std::to_string(dev.index), prec);
        vpffd::CorrectionOptions o;
        vpffd::DeformResult r;
        std::vector<double> gpu;
        const double t_xyz = median_ms(
            [&] {
              r = g.deform(P, o, false);
              gpu.push_back(g.last_timings().gpu_total);
            },
            repeats);
        std::nth_element(gpu.begin(), gpu.begin() + gpu.size() / 2, gpu.end());
        const std::string label = std::string("vulkan ") + (prec == vpffd::vulkan::Precision::Float64 ? "f64" : "ff") +
                                  ", " + dev.name;
        std::printf("%-28s %10s %12.3f %12.3f %12.1e\n", label.substr(0, 28).c_str(), "", t_xyz,
                    gpu[gpu.size() / 2], std::abs(r.volume - r.target_volume) / r.target_volume);
      }
    }
    if (!why.empty()) std::printf("vulkan: %s\n", why.c_str());
#endif
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_frame: %s\n", e.what());
    return 1;
  }
}
