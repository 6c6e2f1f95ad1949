#pragma once
// The walkthrough of Marvie & Bouatouch section 7.1 ("this path passes through all the rooms"):
// every cell visited in serpentine order, walking between cell centres at eye height and
// standing still in each (the static-viewpoint case), looking along the walk. Shared by
// `parallax stream walk --tour`, `parallax bench stream` and the demo.

#include <vector>

#include <plx/core/core.h>

namespace plx::stream {

struct TourConfig {
    double fps = 30.0;        // poses per second of walk
    double speedMps = 1.2;    // walking speed between cell centres (a brisk museum visit)
    double stopS = 10.0;      // seconds standing still at each centre
    float eyeHeight = 1.6f;   // metres above y = 0 (the generators' floors)
    float lookAheadM = 5.0f;  // the target's distance along the heading
};

struct TourPose {
    Vec3 eyePos;
    Vec3 targetPos;
};

// The longest tour roomTour makes (about 9 hours at 30 fps): bounds memory for any cell boxes.
constexpr size_t kMaxTourPoses = 1'000'000;

// The tour through the centres of `cellBoxes`: rows of equal centre z (to a millimetre) in
// ascending z, alternately ascending and descending x, starting at the first centre facing +x,
// standing stopS at each centre (at least one frame, so a tour has a pose at every centre).
// Errors: no boxes, a non-finite box, config outside fps in (0, 1000], speedMps in (0, 100],
// stopS in [0, 3600], or a tour longer than kMaxTourPoses.
Result<std::vector<TourPose>> roomTour(const std::vector<Aabb>& cellBoxes,
                                       const TourConfig& config = {});

}  // namespace plx::stream
