#pragma once
// Parallax core: math, cameras, images, image I/O, errors, timing, parallel helpers, metrics.
//
// ---------------------------------------------------------------------------------------------
// Conventions (every module follows these; keep this block true)
//
// - World space is right-handed with +y up. A camera looks down -z of its own (view) space, as in
//   OpenGL; clip space is OpenGL's (-w <= x, y, z <= w after projection).
// - Pixels: (0,0) is the top-left pixel of an image, x grows right, y grows down. Pixel centres
//   lie at +0.5, so pixel (x, y) is sampled at (x + 0.5, y + 0.5). Rasterisation uses the
//   top-left fill rule: a sample exactly on an edge belongs to the triangle only if the edge is a
//   top edge (horizontal, other vertex below) or a left edge.
// - Depth target: 32-bit float holding 1/w_clip = 1 / (view-space distance along -z), i.e. the
//   reciprocal of eye depth. Why: it is affine in screen space (exact to interpolate), it is
//   directly the generalised disparity (proportional to 1/z) that the warp module needs, and it
//   keeps more float precision far away than z/w does. Larger means nearer; the cleared value is
//   0 (infinitely far) and the depth test passes when the new value is strictly greater, so the
//   first triangle drawn wins exact ties (like GL_LESS on z).
// - Polygon ID target: uint32. 0 = no polygon. Otherwise scene-global triangle index + 1, where
//   the global index counts triangles across the scene's meshes in order.
// - Colour targets are RGBA8 holding sRGB-encoded values, as files do. Shading happens in linear
//   RGB in float (textures are decoded from sRGB before filtering) and is encoded to sRGB when a
//   pixel is written.
// - Units: scene units are metres unless a file says otherwise. Display geometry uses
//   millimetres where its paper does, and says so in the name (`errorMm`).
// - Transforms are named AFromB (`clipFromWorld`, `pixelFromClip`, `displayFromImage`) and
//   compose right to left: clipFromWorld = clipFromView * viewFromWorld.
// - A pointer parameter that a function writes (`WarpFrame* out`) must not be null unless it
//   defaults to nullptr or its comment says it may be null; a null one is a programmer error,
//   not a Status.
// ---------------------------------------------------------------------------------------------

#include <plx/core/camera.h>
#include <plx/core/check.h>
#include <plx/core/color.h>
#include <plx/core/image.h>
#include <plx/core/image_io.h>
#include <plx/core/math.h>
#include <plx/core/metrics.h>
#include <plx/core/parallel.h>
#include <plx/core/status.h>
#include <plx/core/stereo_rig.h>
#include <plx/core/timing.h>
