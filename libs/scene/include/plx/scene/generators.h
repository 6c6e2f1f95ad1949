#pragma once
// Deterministic procedural scenes, addressable as specs ("office:4", "museum:3").
//
// office:N - the P-buffer paper's office room (Heo, Jung, Wohn, section V) "after removing walls
//   and adding posts to make it somewhat open": desks, chairs, partitions, shelves, posts and a
//   floor, about 3,600 triangles per room, replicated N times on a near-square grid as in the
//   paper's Table 1. Default viewpoint: inside the first room looking across the floor, so that
//   the number of visible polygons levels off as N grows.
// museum:N - N textured rooms joined by doorways with paintings on the walls (procedural
//   textures), for the texture-streaming work.

#include <plx/scene/scene.h>

namespace plx::scene {

// Largest N accepted by each generator (keeps specs from asking for absurd memory).
constexpr int kMaxOfficeRooms = 4096;
constexpr int kMaxMuseumRooms = 1024;

Result<Scene> generateOffice(int rooms);
Result<Scene> generateMuseum(int rooms);

// Parses and runs a generator spec. Unknown names and bad counts give kInvalidArgument.
Result<Scene> generateFromSpec(const std::string& spec);

}  // namespace plx::scene
