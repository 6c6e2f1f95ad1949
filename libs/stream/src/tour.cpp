// The walkthrough through every cell (Marvie & Bouatouch 7.1), as a pose list.
#include <plx/stream/tour.h>

#include <algorithm>
#include <cmath>
#include <map>

#include <fmt/format.h>

namespace plx::stream {
namespace {

bool finite(Vec3 v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

Status checkConfig(const TourConfig& c) {
    if (!(c.fps > 0.0 && c.fps <= 1000.0))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("tour fps {} outside (0, 1000]", c.fps));
    if (!(c.speedMps > 0.0 && c.speedMps <= 100.0))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("tour speed {} m/s outside (0, 100]", c.speedMps));
    if (!(c.stopS >= 0.0 && c.stopS <= 3600.0))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("tour stop {} s outside 0 .. 3600", c.stopS));
    if (!std::isfinite(c.eyeHeight) || !(c.lookAheadM > 0.0f))
        return errorStatus(ErrorCode::kInvalidArgument, "tour eye height or look-ahead invalid");
    return Status::ok();
}

}  // namespace

Result<std::vector<TourPose>> roomTour(const std::vector<Aabb>& cellBoxes,
                                       const TourConfig& config) {
    PLX_RETURN_IF_ERROR(checkConfig(config));
    if (cellBoxes.empty()) return errorStatus(ErrorCode::kInvalidArgument, "tour of no cells");
    // Serpentine order of the centres: rows by z (rounded to a millimetre so that rooms of one
    // row share it), alternating x.
    std::map<double, std::vector<Vec3>> rows;
    for (const Aabb& b : cellBoxes) {
        if (!finite(b.lo) || !finite(b.hi))
            return errorStatus(ErrorCode::kInvalidArgument, "tour through a non-finite cell box");
        const Vec3 c = 0.5f * (b.lo + b.hi);
        rows[std::round(double(c.z) * 1000.0)].push_back(c);
    }
    std::vector<Vec3> order;
    bool reverse = false;
    for (auto& [z, row] : rows) {
        std::stable_sort(row.begin(), row.end(),
                         [&](Vec3 a, Vec3 b) { return reverse ? a.x > b.x : a.x < b.x; });
        order.insert(order.end(), row.begin(), row.end());
        reverse = !reverse;
    }
    // Poses: walking at speedMps between centres (the last step short of the next centre), then
    // stopS still at it, at least one frame: every centre is visited, and a tour of one cell
    // with no stop is a pose, not none.
    const double step = config.speedMps / config.fps;
    const size_t still = std::max<size_t>(1, size_t(config.stopS * config.fps));
    size_t count = 0;
    Vec3 here = order.front();
    for (Vec3 next : order) {
        const double distance = std::hypot(double(next.x - here.x), double(next.z - here.z));
        count += size_t(distance / step) + still;
        if (count > kMaxTourPoses)
            return errorStatus(ErrorCode::kInvalidArgument,
                               fmt::format("tour longer than {} poses", kMaxTourPoses));
        here = next;
    }
    std::vector<TourPose> poses;
    poses.reserve(count);
    Vec3 heading(1.0f, 0.0f, 0.0f);
    auto add = [&](Vec3 at) {
        const Vec3 eye(at.x, config.eyeHeight, at.z);
        poses.push_back({eye, eye + config.lookAheadM * heading});
    };
    here = order.front();
    for (Vec3 next : order) {
        const Vec3 delta(next.x - here.x, 0.0f, next.z - here.z);
        const float distance = glm::length(delta);
        if (distance > 1e-6f) heading = delta / distance;
        const size_t steps = size_t(double(distance) / step);
        for (size_t k = 0; k < steps; ++k) add(here + delta * float(double(k) * step / distance));
        here = next;
        for (size_t k = 0; k < still; ++k) add(here);
    }
    return poses;
}

}  // namespace plx::stream
