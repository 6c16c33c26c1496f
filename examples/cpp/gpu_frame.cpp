// One volume-preserving frame on the Vulkan backend (target vpffd::vulkan), in both
// precisions of the device sums, checked against the CPU backend.
#include <cmath>
#include <cstdio>

#include "vpffd/backend/vulkan.h"
#include "vpffd/vpffd.h"

int main() {
  const vpffd::TriMesh sphere = vpffd::icosphere(5);
  const vpffd::Lattice lattice = vpffd::make_lattice({-1.1, -1.1, -1.1}, {1.1, 1.1, 1.1}, {8, 8, 8}, {3, 3, 3});
  const vpffd::RowMatrixX3d P =
      vpffd::twist(vpffd::scale(vpffd::rest_control_points(lattice), {1.0, 1.0, 0.6}, {0.0, 0.0, 0.0}), 1.0, 2,
                   {0.0, 0.0, 0.0});
  const vpffd::DeformResult cpu = vpffd::Deformer(sphere.V, sphere.F, lattice).deform(P, {});
  try {
    for (auto precision : {vpffd::vulkan::Precision::Auto, vpffd::vulkan::Precision::FloatFloat}) {
      // "" takes the first suitable device (GPUs before software ones such as lavapipe).
      vpffd::vulkan::VulkanDeformer gpu(sphere.V, sphere.F, lattice, vpffd::OutsidePolicy::Error, "", precision);
      const vpffd::DeformResult r = gpu.deform(P, {});
      const double vol_err = std::abs(r.volume - r.target_volume) / r.target_volume;
      const double dev = (r.vertices - cpu.vertices).cwiseAbs().maxCoeff();
      const vpffd::vulkan::FrameTimings t = gpu.last_timings();
      std::printf("%s, %s sums: volume error %.1e, vertices within %.1e of the CPU's, GPU %.2f ms\n",
                  gpu.device().name.c_str(), vpffd::vulkan::precision_name(gpu.precision()), vol_err, dev,
                  t.gpu_total);
      if (!(vol_err < 1e-6) || !(dev < 1e-5)) return 1;
    }
  } catch (const vpffd::BackendUnavailableError& e) {
    std::printf("no Vulkan device: %s\n", e.what());
    return 1;
  }
  return 0;
}
