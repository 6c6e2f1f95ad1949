// The warp coefficients of a camera pair (equation.h holds the derivation).

#include <plx/warp/equation.h>

namespace plx::warp {

glm::dmat3 rayFromPixel(const Camera& camera) {
    // pixelFromView from the clip matrix's x, y and w rows (pixelFromClip in camera.h):
    // u w = W/2 (x + w), v w = H/2 (w - y); the w row is (0, 0, -1), so w is the forward depth.
    const glm::dmat4 clip(camera.clipFromView());
    const double halfW = 0.5 * double(camera.width());
    const double halfH = 0.5 * double(camera.height());
    glm::dmat3 pixelFromView;  // glm: [column][row]
    for (int col = 0; col < 3; ++col) {
        pixelFromView[col][0] = halfW * (clip[col][0] + clip[col][3]);
        pixelFromView[col][1] = halfH * (clip[col][3] - clip[col][1]);
        pixelFromView[col][2] = clip[col][3];
    }
    const glm::dmat3 viewFromWorld(glm::dmat4(camera.viewFromWorld()));
    return glm::inverse(pixelFromView * viewFromWorld);
}

WarpCoefficients warpCoefficients(const Camera& source, const Camera& destination) {
    const glm::dmat3 destFromRay = glm::inverse(rayFromPixel(destination));
    const glm::dmat3 m = destFromRay * rayFromPixel(source);
    const glm::dvec3 t =
        destFromRay * (glm::dvec3(source.eyePos()) - glm::dvec3(destination.eyePos()));
    // Source index x sits at u = x + 0.5: the half pixel goes into the constant column.
    WarpCoefficients w;
    w.a = float(m[0][0]);
    w.b = float(m[1][0]);
    w.c = float(t[0]);
    w.k = float(m[2][0] + 0.5 * (m[0][0] + m[1][0]));
    w.d = float(m[0][1]);
    w.e = float(m[1][1]);
    w.f = float(t[1]);
    w.l = float(m[2][1] + 0.5 * (m[0][1] + m[1][1]));
    w.g = float(m[0][2]);
    w.h = float(m[1][2]);
    w.i = float(t[2]);
    w.m = float(m[2][2] + 0.5 * (m[0][2] + m[1][2]));
    return w;
}

glm::dvec3 sourceEpipole(const Camera& source, const Camera& destination) {
    return glm::inverse(rayFromPixel(source)) *
           (glm::dvec3(destination.eyePos()) - glm::dvec3(source.eyePos()));
}

}  // namespace plx::warp
