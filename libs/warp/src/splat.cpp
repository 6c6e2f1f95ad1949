// Reconstruction kernel names (splat.h); the kernels themselves run in the row transform
// (warp_row.inl), the scatter and the mesh rasteriser (warper.cpp).

#include <string>

#include <plx/warp/splat.h>
#include <plx/warp/warp.h>

namespace plx::warp {

Result<Splat> parseSplat(const std::string& name) {
    if (name == "derivative") return Splat::kDerivative;
    if (name == "point") return Splat::kPoint;
    if (name == "fixed") return Splat::kFixed2x2;
    if (name == "mesh") return Splat::kMesh;
    return errorStatus(ErrorCode::kInvalidArgument,
                       "unknown splat '" + name + "' (derivative, point, fixed, mesh)");
}

const char* splatName(Splat splat) {
    switch (splat) {
        case Splat::kDerivative:
            return "derivative";
        case Splat::kPoint:
            return "point";
        case Splat::kFixed2x2:
            return "fixed";
        case Splat::kMesh:
            return "mesh";
    }
    return "?";
}

}  // namespace plx::warp
