#pragma once
// The file access assimp gets while importing a model: every file a model refers to (glTF
// buffers, OBJ material libraries, anything a reader follows) must be a regular file inside the
// model's folder, unless external references are allowed.

#include <filesystem>
#include <optional>
#include <string>

#include <assimp/DefaultIOSystem.h>

#include <plx/core/status.h>

namespace plx::scene {

// Where a model may read from: its folder and below (after resolving "..", absolute paths,
// file:// URIs and symlinks), or anywhere when allowExternal.
class RefPolicy {
public:
    RefPolicy(const std::string& modelPath, bool allowExternal);

    // The file a reference names, resolved, or an error naming the reference and why it is
    // refused (outside the folder, not a regular file, missing). A relative ref is taken
    // relative to the model's folder, or to the working directory when !relativeToModel (assimp
    // passes paths it has already joined to the model's folder).
    Result<std::filesystem::path> resolve(const std::string& ref, bool relativeToModel) const;

private:
    std::filesystem::path mModelDir;  // as given, for relative references
    std::filesystem::path mRoot;      // canonical folder references must stay inside
    std::filesystem::path mModel;     // the canonical model file itself, always allowed
    bool mAllowExternal;
};

// assimp's default file access behind the policy. The first refusal is kept for the import's
// error message: readers treat a file that cannot be opened as a warning or a generic failure.
class ContainedIOSystem : public Assimp::DefaultIOSystem {
public:
    explicit ContainedIOSystem(RefPolicy policy) : mPolicy(std::move(policy)) {}

    bool Exists(const char* file) const override;
    Assimp::IOStream* Open(const char* file, const char* mode = "rb") override;

    const std::optional<Status>& firstRefusal() const { return mRefusal; }

private:
    RefPolicy mPolicy;
    mutable std::optional<Status> mRefusal;
};

}  // namespace plx::scene
