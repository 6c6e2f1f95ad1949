// Dense error measurement of warp meshes.

#include <plx/display/validate.h>

#include <atomic>
#include <cmath>
#include <mutex>

#include <plx/core/parallel.h>

namespace plx::display {

ErrorMeasurement measureMeshError(const Display& display, const ImagePlane& plane,
                                  const WarpMesh& mesh, int divisions, ThreadPool* pool) {
    PLX_CHECK(divisions >= 2);
    ErrorMeasurement total;
    std::mutex lock;
    double sum = 0.0;
    bool mirror = usesMirrorAngles(display);
    auto body = [&](size_t begin, size_t end) {
        ErrorMeasurement local;
        double localSum = 0.0;
        for (size_t t = begin; t < end; ++t) {
            const uint32_t* idx = &mesh.indices[3 * t];
            // Bracket from the mirror angles of the triangle's corners.
            AlphaBracket bracket;
            if (mirror) {
                double lo = 1e300, hi = -1e300, ref = 0.0;
                for (int k = 0; k < 3; ++k) {
                    VertexMapping vm =
                        imageToDisplay(display, plane, plane.pointAt(mesh.uvs[idx[k]]));
                    if (k == 0) ref = vm.alpha;
                    double a = ref + std::remainder(vm.alpha - ref, 6.283185307179586);
                    lo = std::min(lo, a), hi = std::max(hi, a);
                }
                bracket = {lo, hi};
            }
            for (int i = 0; i <= divisions; ++i) {
                for (int j = 0; i + j <= divisions; ++j) {
                    int k = divisions - i - j;
                    if (i == divisions || j == divisions || k == divisions) continue;
                    double wa = double(i) / divisions, wb = double(j) / divisions,
                           wc = double(k) / divisions;
                    DVec2 q = wa * mesh.displayPos[idx[0]] + wb * mesh.displayPos[idx[1]] +
                              wc * mesh.displayPos[idx[2]];
                    DVec2 uv = wa * mesh.uvs[idx[0]] + wb * mesh.uvs[idx[1]] +
                               wc * mesh.uvs[idx[2]];
                    double e = sampleErrorMm(display, plane, q, uv, bracket, nullptr);
                    if (!std::isfinite(e)) {
                        ++local.unmapped;
                        continue;
                    }
                    ++local.samples;
                    localSum += e;
                    local.maxErrorMm = std::max(local.maxErrorMm, e);
                }
            }
        }
        std::lock_guard<std::mutex> guard(lock);
        total.maxErrorMm = std::max(total.maxErrorMm, local.maxErrorMm);
        total.samples += local.samples;
        total.unmapped += local.unmapped;
        sum += localSum;
    };
    size_t count = mesh.triangleCount();
    if (pool) pool->parallelFor(count, 256, body);
    else body(0, count);
    total.meanErrorMm = total.samples ? sum / double(total.samples) : 0.0;
    return total;
}

}  // namespace plx::display
