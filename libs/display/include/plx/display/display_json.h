#pragma once
// Display description files (JSON). Lengths are in the file's "units" ("mm", "cm" or "m"; mm
// when absent) and converted to millimetres; every length lies within +-1e7 mm (10 km). Layout:
//
// {
//   "name": "cone showcase",                 optional string
//   "units": "mm",                           optional
//   "optics": {                              required
//     "type": "cone_mirror",                 cone_mirror | cylinder_mirror | cylinder_screen |
//                                            dome_screen
//     cone_mirror:     "bottom_radius", "top_radius", "height"   (radii > 0, top > bottom)
//     cylinder_mirror: "radius", "height"
//     both mirrors:    optional "sheet": {"thickness": >= 0, "refractive_index": >= 1}
//     cylinder_screen: "center": [x,y,z], "radius"; dome_screen: "center", "radius"
//     both screens:    "projector": {"position", "target", "up" (optional), "fov_y" (degrees),
//                                    "resolution": [w, h]}
//   },
//   "display": {"min": [x, z], "max": [x, z], "framebuffer": [w, h]}   required for mirrors
//                (screen-plane rectangle shown); screens default to the projector's pixels
//   "viewer": [x, y, z],                     required: default viewer position
//   "content": {"center": [x, y, z], "radius": r}   required: bounding sphere of the content
// }

#include <string>
#include <string_view>

#include <plx/core/status.h>
#include <plx/display/optics.h>

namespace plx::display {

// Parses a display description (the file's bytes). Errors name the field and the problem in one
// line ("optics.bottom_radius: must be a positive number").
Result<Display> parseDisplayJson(std::string_view text);

// Reads and parses a display file; errors are prefixed with the path.
Result<Display> loadDisplayFile(const std::string& path);

// The checks parseDisplayJson applies beyond reading, for displays built in code: positive radii
// and heights, framebuffer and projector sides in 1..16384 pixels, the projector's field of view
// and orientation, the mirror sheet, the viewer outside the content sphere and, for mirrors,
// outside the mirror (inside the screen for projection displays).
Status validateDisplay(const Display& display);

}  // namespace plx::display
