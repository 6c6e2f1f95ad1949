#pragma once
// Deterministic procedural scenes, addressable as specs ("office:4", "museum:3", "showcase").
//
// office:N - the P-buffer paper's office room (Heo, Jung, Wohn, section V) "after removing walls
//   and adding posts to make it somewhat open": desks, chairs, partitions, shelves, posts and a
//   floor, 3,632 triangles per 8 m x 8 m room (the paper's room has 3,652 polygons), replicated
//   N times on a near-square grid of ceil(sqrt(N)) columns as in the paper's Table 1, one merged
//   mesh per material. Viewpoints: "default" inside the corner room at eye height looking
//   diagonally across the floor, 32 degrees down (the top of the view just below the horizon),
//   so that the number of visible polygons levels off as N grows; "vista" from the same place
//   12 degrees down, over the whole grid to the horizon; "overview" from above.
// museum:N - N 10 m x 10 m textured rooms on a near-square grid joined by doorways, one painting
//   per wall (each with its own procedural 256x256, 512x512 or 512x256 texture, up to 128
//   distinct ones), tiled floor and plaster walls. Viewpoints: "default" in room 0 looking
//   through the doorway along +x, "overview".
// showcase - a small exhibit for the curved displays (Bimber et al.): a stone pedestal and a
//   bronze figure of three spheres, 0.69 units tall, 1,492 triangles, no textures. It is the
//   content fitted to a display's content sphere when no scene is given. Viewpoint: "default",
//   framing the exhibit.
// Metres, y up; all faces wound counter-clockwise seen from outside with outward normals.

#include <plx/scene/scene.h>

namespace plx::scene {

// Largest N accepted by each generator (keeps specs from asking for absurd memory).
constexpr int kMaxOfficeRooms = 4096;
constexpr int kMaxMuseumRooms = 1024;

// The office with `rooms` copies of the room. Errors: rooms outside 1..kMaxOfficeRooms.
Result<Scene> generateOffice(int rooms);
// The museum with `rooms` rooms. Errors: rooms outside 1..kMaxMuseumRooms.
Result<Scene> generateMuseum(int rooms);

// The showcase exhibit. Never fails; a Result like the other generators.
Result<Scene> generateShowcase();

// True for the generators whose spec is their bare name, without a count ("showcase").
bool isCountFreeGenerator(const std::string& name);

// Parses and runs a generator spec. Unknown names, bad counts and a count given to a count-free
// generator give kInvalidArgument.
Result<Scene> generateFromSpec(const std::string& spec);

// An upper bound on the triangles generateFromSpec(spec) makes, found without making them (for
// memory checks before a large scene is generated): N times the one-room scene's for office:N
// (exact: its rooms are copies) and museum:N (its rooms share walls: fewer), the count itself for
// a count-free generator. Errors as generateFromSpec's.
Result<size_t> generatedTriangleBound(const std::string& spec);

}  // namespace plx::scene
