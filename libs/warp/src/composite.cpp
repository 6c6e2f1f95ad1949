// Which set wins near-equal depths when several are composited (holes.h; Mark, Bishop,
// McMillan, "Improving Quality of Final Images": several source images, chosen by quality).

#include <plx/core/math.h>
#include <plx/warp/holes.h>
#include <plx/warp/warp.h>

namespace plx::warp {

std::vector<float> compositeDepthScales(std::span<const ReferenceSet* const> sets,
                                        const Camera& destination, float tolerance) {
    std::vector<float> scales(sets.size(), 1.0f);
    if (sets.size() < 2 || !(tolerance > 0.0f)) return scales;
    // The warp's errors (stretched splats, newly uncovered surfaces) grow with the translation
    // between reference and destination; rotation alone is exact. Ties: the earlier set.
    size_t best = 0;
    float bestDistance = glm::length(sets[0]->pose.eye - destination.eyePos());
    for (size_t s = 1; s < sets.size(); ++s) {
        const float d = glm::length(sets[s]->pose.eye - destination.eyePos());
        if (d < bestDistance) best = s, bestDistance = d;
    }
    for (size_t s = 0; s < sets.size(); ++s)
        if (s != best) scales[s] = 1.0f / (1.0f + tolerance);
    return scales;
}

}  // namespace plx::warp
