// Display optics: image plane, mirror reflection with refraction, curved screens and the
// object-image solver (Bimber et al. sections 2, 7.2, 7.3 and 9).

#include <plx/display/optics.h>

#include <cmath>
#include <limits>

#include "brent.h"

namespace plx::display {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kTwoPi = 6.283185307179586;
// Brent stops once Delta (display-plane mismatch) is below this.
constexpr double kDeltaTargetMm = kObjectImageToleranceMm;
// A solve counts as converged below this Delta; above it the bracket is widened.
constexpr double kDeltaAcceptMm = 5e-3;
constexpr int kMaxBrentEvaluations = 60;
// Samples of the fallback scan over a widened bracket.
constexpr int kScanSamples = 32;

// Smallest t > 0 where the ray o + t d meets the real nappe of the cone r(y) = r0 + k y
// (r > 0); the cone's implicit form is x^2 + z^2 - (r0 + k y)^2 = 0.
bool intersectCone(const ConeMirror& cone, const DVec3& o, const DVec3& d, double* tHit) {
    double k = cone.slope();
    double r0 = cone.bottomRadiusMm;
    double ro = r0 + k * o.y;
    double a = d.x * d.x + d.z * d.z - k * k * d.y * d.y;
    double b = 2.0 * (o.x * d.x + o.z * d.z - k * ro * d.y);
    double c = o.x * o.x + o.z * o.z - ro * ro;
    double roots[2];
    int count = 0;
    if (std::fabs(a) < 1e-12) {
        if (std::fabs(b) < 1e-12) return false;
        roots[count++] = -c / b;
    } else {
        double disc = b * b - 4.0 * a * c;
        if (disc < 0.0) return false;
        double s = std::sqrt(disc);
        // Numerically stable pair of roots.
        double q = -0.5 * (b + (b >= 0.0 ? s : -s));
        roots[count++] = q / a;
        if (q != 0.0) roots[count++] = c / q;
        if (count == 2 && roots[1] < roots[0]) std::swap(roots[0], roots[1]);
    }
    for (int i = 0; i < count; ++i) {
        double t = roots[i];
        if (t <= 1e-9) continue;
        if (r0 + k * (o.y + t * d.y) <= 0.0) continue;
        *tHit = t;
        return true;
    }
    return false;
}

// Outward unit normal of the cone at a point on it: the gradient of
// g = sqrt(x^2 + z^2) - (r0 + k y) is (cos a, -k, sin a) / sqrt(1 + k^2) along the ruling at
// angle a; without trigonometry (cos a, sin a) = (x, z) / r with
// r = r0 + k y, the cone's radius at the point's height.
DVec3 coneNormalAt(const ConeMirror& cone, const DVec3& hit) {
    double k = cone.slope();
    double inv = 1.0 / std::sqrt(1.0 + k * k);
    double r = cone.bottomRadiusMm + k * hit.y;
    double s = inv / r;
    return DVec3(hit.x * s, -k * inv, hit.z * s);
}

// Reflects the line of sight with direction d (unit) at the mirror and follows it to the
// display plane y = 0 (the image-object transformation of Fig. 2-center). The mirror angle
// (atan2) is computed only when alphaOut is given: the residual of section 7.3 does not need it.
bool mirrorDirToDisplay(const ConeMirror& cone, const DVec3& eye, const DVec3& d, DVec2* posOut,
                        double* alphaOut) {
    double t;
    if (!intersectCone(cone, eye, d, &t)) return false;
    DVec3 hit = eye + t * d;
    DVec3 n = coneNormalAt(cone, hit);
    double dn = glm::dot(d, n);
    if (dn >= 0.0) return false;  // the line would meet the mirror from inside
    DVec3 reflected = d - 2.0 * dn * n;
    if (reflected.y > -1e-9) return false;  // reflected away from the display plane
    double s = -hit.y / reflected.y;
    *posOut = {hit.x + s * reflected.x, hit.z + s * reflected.z};
    if (alphaOut) *alphaOut = std::atan2(hit.z, hit.x);
    return true;
}

bool mirrorDirToDisplay(const ConeMirror& cone, const DVec3& eye, const DVec3& d,
                        VertexMapping* out) {
    if (!mirrorDirToDisplay(cone, eye, d, &out->displayPos, &out->alpha)) return false;
    out->valid = true;
    return true;
}

// Lateral shift of a line of sight with direction d (unit) after crossing the mirror sheet, a
// locally plane-parallel slab of thickness h and index eta whose outer surface the line meets.
// The line leaves the slab parallel to d, displaced by the returned vector (Snell's law).
DVec3 sheetShift(const ConeMirror& cone, const DVec3& eye, const DVec3& d) {
    double t;
    if (!intersectCone(cone, eye, d, &t)) return DVec3(0.0);
    DVec3 hit = eye + t * d;
    DVec3 nIn = -coneNormalAt(cone, hit);
    double cosI = glm::dot(d, nIn);
    if (cosI <= 1e-6) return DVec3(0.0);
    double eta = 1.0 / cone.refractiveIndex;
    double k = 1.0 - eta * eta * (1.0 - cosI * cosI);
    if (k <= 0.0) return DVec3(0.0);
    double cosT = std::sqrt(k);
    DVec3 dT = eta * d + (eta * cosI - cosT) * nIn;  // refracted direction (unit)
    double h = cone.sheetThicknessMm;
    DVec3 delta = (h / cosT) * dT - (h / cosI) * d;
    return delta - glm::dot(delta, d) * d;
}

// Direction of the line of sight that shows content point p: p itself when refraction is off,
// otherwise the line whose refracted continuation passes through p (fixed-point iteration; the
// shift changes slowly with the direction, three steps reach micrometres).
DVec3 sightDirFor(const ConeMirror& cone, const DVec3& eye, const DVec3& p) {
    DVec3 d = glm::normalize(p - eye);
    if (cone.sheetThicknessMm <= 0.0) return d;
    for (int i = 0; i < 3; ++i) d = glm::normalize(p - sheetShift(cone, eye, d) - eye);
    return d;
}

// Image-plane point shown along the line of sight d (the inverse of sightDirFor).
bool imagePointForSight(const ConeMirror& cone, const ImagePlane& plane, const DVec3& d,
                        DVec3* out) {
    DVec3 shift = cone.sheetThicknessMm > 0.0 ? sheetShift(cone, plane.eyeMm, d) : DVec3(0.0);
    double fd = glm::dot(plane.forwardDir, d);
    if (fd <= 1e-9) return false;
    DVec3 centre = plane.eyeMm + plane.distanceMm * plane.forwardDir;
    double lambda = glm::dot(plane.forwardDir, centre - plane.eyeMm - shift) / fd;
    *out = plane.eyeMm + lambda * d + shift;
    return true;
}

// Far intersection (t > 0) of a ray starting inside the screen surface.
bool intersectScreenFromInside(const ProjectedScreen& screen, const DVec3& o, const DVec3& d,
                               DVec3* hit) {
    double a, b, c;
    if (const auto* cyl = std::get_if<CylinderScreen>(&screen.surface)) {
        DVec3 q = o - cyl->centerMm;
        a = d.x * d.x + d.z * d.z;
        b = 2.0 * (q.x * d.x + q.z * d.z);
        c = q.x * q.x + q.z * q.z - cyl->radiusMm * cyl->radiusMm;
    } else {
        const auto& dome = std::get<DomeScreen>(screen.surface);
        DVec3 q = o - dome.centerMm;
        a = glm::dot(d, d);
        b = 2.0 * glm::dot(q, d);
        c = glm::dot(q, q) - dome.radiusMm * dome.radiusMm;
    }
    if (a < 1e-12 || c >= 0.0) return false;  // parallel to the axis, or starting outside
    double disc = b * b - 4.0 * a * c;        // > 0 since c < 0
    double t = (-b + std::sqrt(disc)) / (2.0 * a);
    if (t <= 0.0) return false;
    *hit = o + t * d;
    return true;
}

struct ProjectorFrame {
    DVec3 forward, right, up;
    double tanHalfY, aspect;
};

ProjectorFrame projectorFrame(const Projector& p) {
    ProjectorFrame f;
    f.forward = glm::normalize(p.targetMm - p.posMm);
    f.right = glm::normalize(glm::cross(f.forward, p.upDir));
    f.up = glm::cross(f.right, f.forward);
    f.tanHalfY = std::tan(0.5 * p.fovYDegrees * 3.141592653589793 / 180.0);
    f.aspect = double(p.widthPx) / double(p.heightPx);
    return f;
}

bool projectToProjector(const Projector& p, const DVec3& worldMm, DVec2* pixel) {
    ProjectorFrame f = projectorFrame(p);
    DVec3 rel = worldMm - p.posMm;
    double depth = glm::dot(rel, f.forward);
    if (depth <= 1e-6) return false;
    double ndcX = glm::dot(rel, f.right) / (depth * f.tanHalfY * f.aspect);
    double ndcY = glm::dot(rel, f.up) / (depth * f.tanHalfY);
    *pixel = {(ndcX * 0.5 + 0.5) * p.widthPx, (0.5 - ndcY * 0.5) * p.heightPx};
    return true;
}

DVec3 projectorRayDir(const Projector& p, const DVec2& pixel) {
    ProjectorFrame f = projectorFrame(p);
    double ndcX = 2.0 * pixel.x / p.widthPx - 1.0;
    double ndcY = 1.0 - 2.0 * pixel.y / p.heightPx;
    return glm::normalize(f.forward + ndcX * f.tanHalfY * f.aspect * f.right +
                          ndcY * f.tanHalfY * f.up);
}

// Residual of section 7.3 for mirror angle alpha: reflect the display point over the tangent
// plane TP1 at alpha, look at the reflection from the eye, map that line of sight back to the
// display through TP2 at its true mirror point, and measure the mismatch Delta. Returned squared
// so that the minimum is parabolic, which Brent's interpolation assumes.
double mirrorResidualSq(const ConeMirror& cone, const DVec3& eye, const DVec3& q3, double alpha,
                        DVec3* sightDir) {
    double c = std::cos(alpha), s = std::sin(alpha);
    double k = cone.slope();
    double inv = 1.0 / std::sqrt(1.0 + k * k);
    DVec3 n(c * inv, -k * inv, s * inv);  // coneNormal(cone, alpha)
    DVec3 p(cone.bottomRadiusMm * c, 0.0, cone.bottomRadiusMm * s);  // the ruling's foot
    DVec3 mirrored = q3 - 2.0 * glm::dot(q3 - p, n) * n;
    DVec3 d = glm::normalize(mirrored - eye);
    DVec2 back;
    if (!mirrorDirToDisplay(cone, eye, d, &back, nullptr)) return 1e12;
    *sightDir = d;
    DVec2 diff = back - DVec2(q3.x, q3.z);
    return glm::dot(diff, diff);
}

bool mirrorDisplayToImage(const ConeMirror& cone, const ImagePlane& plane,
                          const DVec2& displayPos, const AlphaBracket& bracket, DVec3* imagePos,
                          double* residualMm, SolverStats* stats) {
    DVec3 q3(displayPos.x, 0.0, displayPos.y);
    // The line of sight of the best angle seen so far, so that the minimum needs no second
    // evaluation once Brent stops (Brent returns the best point it evaluated).
    DVec3 dir(0.0), bestDir(0.0);
    double bestF = kInf;
    auto f = [&](double alpha) {
        double v = mirrorResidualSq(cone, plane.eyeMm, q3, alpha, &dir);
        if (v < bestF) bestF = v, bestDir = dir;
        return v;
    };
    auto finish = [&](const BrentResult& r) {
        if (stats) stats->evaluations += uint64_t(r.evaluations);
        double delta = std::sqrt(r.fx);
        if (delta > kDeltaAcceptMm) return false;
        if (residualMm) *residualMm = delta;
        return true;
    };
    if (stats) ++stats->solves;
    // Section 7.3: Brent's method restricted to [alpha1, alpha2] from the lower LOD. With a
    // guess (the mean angle of the sample's edge) a narrow bracket about it is tried first,
    // which saves the golden-section steps across the whole parent range.
    double pad = 0.25 * (bracket.hi - bracket.lo) + 1e-4;
    double lo = bracket.lo - pad, hi = bracket.hi + pad;
    if (std::isfinite(bracket.guess)) {
        double w = 0.02 * (hi - lo) + 1e-6;
        BrentResult r = brentMinimize(f, bracket.guess - w, bracket.guess + w, bracket.guess,
                                      1e-10, kDeltaTargetMm * kDeltaTargetMm,
                                      kMaxBrentEvaluations);
        if (finish(r)) return imagePointForSight(cone, plane, bestDir, imagePos);
    }
    BrentResult r = brentMinimize(f, lo, hi, bracket.guess, 1e-10,
                                  kDeltaTargetMm * kDeltaTargetMm, kMaxBrentEvaluations);
    if (finish(r)) return imagePointForSight(cone, plane, bestDir, imagePos);
    // Fallback: the residual can be a narrow valley next to angles whose lines of sight miss
    // the mirror (near its silhouette), where the first search loses its way. Scan a widened
    // bracket for the best sample and search again around it.
    if (stats) ++stats->widened;
    for (int attempt = 0; attempt < 2; ++attempt) {
        double mid = 0.5 * (lo + hi);
        double half = std::min(1.5 * (hi - lo) + 1e-3, kTwoPi * 0.5);
        double a = mid - half, step = 2.0 * half / kScanSamples;
        double bestX = a, bestScan = kInf;
        for (int i = 0; i <= kScanSamples; ++i) {
            double fx = f(a + i * step);
            if (fx < bestScan) bestScan = fx, bestX = a + i * step;
        }
        if (stats) stats->evaluations += kScanSamples + 1;
        r = brentMinimize(f, bestX - step, bestX + step, bestX, 1e-12,
                          kDeltaTargetMm * kDeltaTargetMm, kMaxBrentEvaluations);
        if (finish(r)) return imagePointForSight(cone, plane, bestDir, imagePos);
        lo = a, hi = a + 2.0 * half;
    }
    if (stats) ++stats->failed;
    if (residualMm) *residualMm = kInf;
    return false;
}

}  // namespace

DVec2 ImagePlane::uvOf(const DVec3& p) const {
    DVec3 rel = p - originMm;
    return {glm::dot(rel, uAxisMm) / (widthMm * widthMm),
            glm::dot(rel, vAxisMm) / (heightMm * heightMm)};
}

bool ImagePlane::projectFromEye(const DVec3& p, DVec3* onPlane) const {
    double depth = glm::dot(p - eyeMm, forwardDir);
    if (depth <= 1e-9) return false;
    *onPlane = eyeMm + (p - eyeMm) * (distanceMm / depth);
    return true;
}

ImagePlane makeImagePlane(const DVec3& eyeMm, const DVec3& centerMm, double radiusMm) {
    ImagePlane plane;
    DVec3 toCentre = centerMm - eyeMm;
    double dist = glm::length(toCentre);
    plane.eyeMm = eyeMm;
    plane.forwardDir = toCentre / dist;
    DVec3 worldUp(0.0, 1.0, 0.0);
    if (std::fabs(glm::dot(worldUp, plane.forwardDir)) > 0.999) worldUp = DVec3(0.0, 0.0, -1.0);
    DVec3 right = glm::normalize(glm::cross(plane.forwardDir, worldUp));
    DVec3 up = glm::cross(right, plane.forwardDir);
    // Symmetric frustum tangent to the bounding sphere (section 7.1): half-angle asin(R / dist).
    double halfAngle = std::asin(std::min(radiusMm / dist, 0.999));
    double half = dist * std::tan(halfAngle);
    plane.distanceMm = dist;
    plane.widthMm = plane.heightMm = 2.0 * half;
    plane.originMm = centerMm - half * right + half * up;
    plane.uAxisMm = 2.0 * half * right;
    plane.vAxisMm = -2.0 * half * up;
    plane.fovYDegrees = 2.0 * halfAngle * 180.0 / 3.141592653589793;
    return plane;
}

VertexMapping imageToDisplay(const Display& display, const ImagePlane& plane,
                             const DVec3& imagePosMm) {
    VertexMapping out;
    if (const auto* cone = std::get_if<ConeMirror>(&display.optics)) {
        DVec3 d = sightDirFor(*cone, plane.eyeMm, imagePosMm);
        if (!mirrorDirToDisplay(*cone, plane.eyeMm, d, &out)) out.valid = false;
        return out;
    }
    const auto& screen = std::get<ProjectedScreen>(display.optics);
    DVec3 hit;
    DVec3 d = glm::normalize(imagePosMm - plane.eyeMm);
    if (!intersectScreenFromInside(screen, plane.eyeMm, d, &hit)) return out;
    out.valid = projectToProjector(screen.projector, hit, &out.displayPos);
    return out;
}

bool displayToImage(const Display& display, const ImagePlane& plane, const DVec2& displayPos,
                    const AlphaBracket& bracket, DVec3* imagePosMm, double* residualMm,
                    SolverStats* stats) {
    if (const auto* cone = std::get_if<ConeMirror>(&display.optics))
        return mirrorDisplayToImage(*cone, plane, displayPos, bracket, imagePosMm, residualMm,
                                    stats);
    const auto& screen = std::get<ProjectedScreen>(display.optics);
    if (residualMm) *residualMm = 0.0;
    DVec3 hit;
    DVec3 d = projectorRayDir(screen.projector, displayPos);
    if (!intersectScreenFromInside(screen, screen.projector.posMm, d, &hit)) return false;
    return plane.projectFromEye(hit, imagePosMm);
}

double sampleErrorMm(const Display& display, const ImagePlane& plane, const DVec2& displayPos,
                     const DVec2& desiredUv, const AlphaBracket& bracket, SolverStats* stats) {
    DVec3 desired = plane.pointAt(desiredUv);
    if (std::holds_alternative<ConeMirror>(display.optics)) {
        DVec3 actual;
        if (!displayToImage(display, plane, displayPos, bracket, &actual, nullptr, stats))
            return kInf;
        return glm::length(actual - desired);  // image space error, section 7.2
    }
    // Curved screens: object space error on the screen surface (section 9).
    const auto& screen = std::get<ProjectedScreen>(display.optics);
    DVec3 wanted, landed;
    if (!intersectScreenFromInside(screen, plane.eyeMm, glm::normalize(desired - plane.eyeMm),
                                   &wanted))
        return kInf;
    DVec3 d = projectorRayDir(screen.projector, displayPos);
    if (!intersectScreenFromInside(screen, screen.projector.posMm, d, &landed)) return kInf;
    return glm::length(landed - wanted);
}

std::string opticsKindName(const Display& display) {
    if (const auto* cone = std::get_if<ConeMirror>(&display.optics))
        return cone->topRadiusMm == cone->bottomRadiusMm ? "cylinder_mirror" : "cone_mirror";
    const auto& screen = std::get<ProjectedScreen>(display.optics);
    return std::holds_alternative<CylinderScreen>(screen.surface) ? "cylinder_screen"
                                                                  : "dome_screen";
}

bool usesMirrorAngles(const Display& display) {
    return std::holds_alternative<ConeMirror>(display.optics);
}

}  // namespace plx::display
