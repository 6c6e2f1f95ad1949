#pragma once
// The import without its last step, for the isolated import's child process: the parent
// finalizes the scene it decodes anyway (the bytes are untrusted, so it re-checks every index and
// reference), and finalizing once saves the child a pass over the whole scene.

#include <plx/scene/import.h>

namespace plx::scene {

// importFile in this process (options.isolation is ignored) up to, not including,
// Scene::finalize: normals may be unnormalised, face normals and bounds are not computed.
// Errors name the file.
Result<Scene> importFileUnfinalized(const std::string& path, const ImportOptions& options);

}  // namespace plx::scene
