#pragma once
// Display optics for image predistortion (Bimber et al., "Real-time view-dependent image warping
// to correct non-linear distortion for curved Virtual Showcase displays"). The two display
// specific components of the paper (section 9) live here as free functions over a Display:
// imageToDisplay() is the per-vertex mapping of TransformPatchVertices, sampleErrorMm() is the
// error measure of RefineFurther.
//
// Frames and units: everything is in world millimetres, right-handed, +y up. Mirror displays put
// the horizontal display screen on the plane y = 0 (its 2D display coordinates are world (x, z));
// the mirror is a surface of revolution about the +y axis through the origin. Projection displays
// use the projector's pixel coordinates (x right, y down, as in the Conventions block) as 2D
// display coordinates. Computations run in double precision: Brent's method resolves the mirror
// point to micrometres at coordinates of hundreds of millimetres.

#include <cstdint>
#include <limits>
#include <string>
#include <variant>

#include <glm/glm.hpp>

namespace plx::display {

using DVec2 = glm::dvec2;
using DVec3 = glm::dvec3;

// A half-silvered conical mirror (the cone-shaped Virtual Showcase) standing on the horizontal
// display y = 0: radius r(y) = bottomRadiusMm + (topRadiusMm - bottomRadiusMm) * y / heightMm.
// The viewer, outside, sees the display reflected by the outer surface, so the cone must widen
// upwards (topRadiusMm > bottomRadiusMm) for a display below it; equal radii give the cylindrical
// mirror. The surface is extended beyond [0, heightMm] for the mathematics; the physical sheet
// clips the visible image there (as in the paper's Fig. 11).
struct ConeMirror {
    double bottomRadiusMm = 150.0;
    double topRadiusMm = 250.0;
    double heightMm = 400.0;
    // Optional refraction through the mirror sheet (acrylic): the content seen through the sheet
    // is shifted by the sheet, and the reflected image is shifted by the same amount so the two
    // stay registered. thicknessMm = 0 disables it.
    double sheetThicknessMm = 0.0;
    double refractiveIndex = 1.49;

    // Slope dr/dy of the generating line.
    double slope() const { return (topRadiusMm - bottomRadiusMm) / heightMm; }
};

// A pinhole projector: pixels (x right, y down, centres at +0.5) of a widthPx x heightPx image.
struct Projector {
    DVec3 posMm{0.0, 0.0, 0.0};
    DVec3 targetMm{0.0, 0.0, -1.0};
    DVec3 upDir{0.0, 1.0, 0.0};
    double fovYDegrees = 60.0;
    int widthPx = 1024;
    int heightPx = 768;
};

// Inside of a vertical cylinder of radius radiusMm about the y axis through centerMm.
struct CylinderScreen {
    DVec3 centerMm{0.0};
    double radiusMm = 1500.0;
};

// Inside of a sphere (a dome) of radius radiusMm about centerMm.
struct DomeScreen {
    DVec3 centerMm{0.0};
    double radiusMm = 1500.0;
};

// A curved projection screen lit by one projector; the viewer looks at the screen from inside.
struct ProjectedScreen {
    std::variant<CylinderScreen, DomeScreen> surface;
    Projector projector;
};

using Optics = std::variant<ConeMirror, ProjectedScreen>;

// A display as described by a display JSON file (see display_json.h).
struct Display {
    std::string name;
    Optics optics;
    // Rectangle of 2D display coordinates that the display framebuffer shows, and its pixel size.
    // Mirror displays: millimetres on the screen plane; projection displays: projector pixels.
    DVec2 displayMin{-300.0, -300.0};
    DVec2 displayMax{300.0, 300.0};
    int framebufferWidth = 1024;
    int framebufferHeight = 1024;
    // Used when the viewer position is not given on the command line.
    DVec3 defaultViewerMm{0.0, 600.0, 900.0};
    // Bounding sphere of the presented content (pass 1's frustum is fitted to it, section 7.1).
    DVec3 contentCenterMm{0.0, 200.0, 0.0};
    double contentRadiusMm = 120.0;
};

// The viewer's image plane: pass 1's symmetric frustum cut by the plane through the content
// centre perpendicular to the optical axis (paper section 2). Texture coordinates (u, v) in
// [0, 1]^2 run right and down, so (0, 0) is the top-left pixel corner of the pass-1 image.
struct ImagePlane {
    DVec3 eyeMm{0.0};
    DVec3 originMm{0.0};   // world position of (u, v) = (0, 0)
    DVec3 uAxisMm{1.0, 0.0, 0.0};  // world vector from u = 0 to u = 1 (length = width)
    DVec3 vAxisMm{0.0, -1.0, 0.0}; // world vector from v = 0 to v = 1 (length = height)
    DVec3 forwardDir{0.0, 0.0, -1.0};  // unit optical axis
    double widthMm = 1.0;
    double heightMm = 1.0;
    double distanceMm = 1.0;  // from the eye to the plane along forwardDir
    double fovYDegrees = 60.0;

    DVec3 pointAt(DVec2 uv) const { return originMm + uv.x * uAxisMm + uv.y * vAxisMm; }
    // Texture coordinates of a world point lying on the plane.
    DVec2 uvOf(const DVec3& p) const;
    // Where the line from the eye through p meets the plane; false when p is not in front.
    bool projectFromEye(const DVec3& p, DVec3* onPlane) const;
};

// The image plane for a viewer at eyeMm framing the sphere (centerMm, radiusMm).
// Preconditions: the eye lies outside the sphere; all values finite.
ImagePlane makeImagePlane(const DVec3& eyeMm, const DVec3& centerMm, double radiusMm);

// One image-grid vertex after TransformPatchVertices.
struct VertexMapping {
    DVec2 displayPos{0.0};  // 2D display coordinates (see the header comment)
    double alpha = 0.0;     // mirror: angle about the axis of the reflection point (radians)
    bool valid = false;     // false: the line of sight misses the optics or the display
};

// Maps an image-plane point to the display (TransformPatchVertices for one vertex, section 6):
// mirror: intersect the line of sight with the mirror, reflect it and intersect the display plane
// (Fig. 2-center), with the sheet's refraction shift first when enabled; screen: intersect the
// line of sight with the screen and project the hit into the projector.
VertexMapping imageToDisplay(const Display& display, const ImagePlane& plane,
                             const DVec3& imagePosMm);

// Angular interval [lo, hi] (radians, lo <= hi, unwrapped) that brackets a mirror angle, and
// a first guess inside it (NaN: start in the middle).
struct AlphaBracket {
    double lo = 0.0;
    double hi = 0.0;
    double guess = std::numeric_limits<double>::quiet_NaN();
};

// The object-image solvers stop once the display-plane mismatch Delta is below this: two orders
// of magnitude under the smallest threshold of the experiment (0.1 mm), as in section 7.3.
constexpr double kObjectImageToleranceMm = 1e-3;

// Counters of the numerical object-image solver (section 7.3).
struct SolverStats {
    uint64_t solves = 0;       // Brent solves (displayToImage on a mirror)
    uint64_t evaluations = 0;  // evaluations of the residual Delta(alpha)
    uint64_t newtonSolves = 0;         // samples solved by Newton steps on the forward mapping
    uint64_t forwardEvaluations = 0;   // image-to-display mappings those steps made
    uint64_t widened = 0;      // solves that fell back to scanning a wider bracket
    uint64_t failed = 0;       // solves that found no point with Delta below tolerance
};

// Object-image reflection (section 7.3): the image-plane point at which the viewer sees the
// display point displayPos. Mirrors use Brent's method over the mirror angle within `bracket`
// (widened when the minimum is not inside); screens are analytic. Returns false when no image
// exists (the point cannot be seen through the optics). residualMm receives Delta (mirror) or 0.
bool displayToImage(const Display& display, const ImagePlane& plane, const DVec2& displayPos,
                    const AlphaBracket& bracket, DVec3* imagePosMm, double* residualMm,
                    SolverStats* stats);

// Error of one sample (section 7.2): a pixel with texture coordinates desiredUv that the warped
// mesh puts at displayPos. Mirror: image space error |v_d - v_a| on the image plane; screens:
// object space error on the screen surface (section 9), both in millimetres. Returns +inf when
// the sample cannot be seen.
double sampleErrorMm(const Display& display, const ImagePlane& plane, const DVec2& displayPos,
                     const DVec2& desiredUv, const AlphaBracket& bracket, SolverStats* stats);

// Name of the optics kind ("cone_mirror", "cylinder_mirror", "cylinder_screen", "dome_screen").
std::string opticsKindName(const Display& display);

// Whether the display's optics need the mirror-angle bracket (mirrors) or not (screens).
bool usesMirrorAngles(const Display& display);

}  // namespace plx::display
