#include "contained_io.h"

#include <fmt/format.h>

#include <plx/core/file.h>

namespace plx::scene {
namespace {

namespace fs = std::filesystem;

bool isInside(const fs::path& p, const fs::path& root) {
    auto rel = p.lexically_relative(root);
    return !rel.empty() && *rel.begin() != ".." && !rel.is_absolute();
}

fs::path canonicalOrSelf(const fs::path& p) {
    std::error_code ec;
    fs::path c = fs::weakly_canonical(fs::absolute(p, ec), ec);
    return ec ? fs::absolute(p).lexically_normal() : c;
}

}  // namespace

RefPolicy::RefPolicy(const std::string& modelPath, bool allowExternal)
    : mModelDir(fs::path(modelPath).parent_path()),
      mRoot(canonicalOrSelf(mModelDir.empty() ? fs::path(".") : mModelDir)),
      mModel(canonicalOrSelf(modelPath)),
      mAllowExternal(allowExternal) {}

Result<fs::path> RefPolicy::resolve(const std::string& ref, bool relativeToModel) const {
    std::string name = ref;
    if (name.rfind("file://", 0) == 0) name = name.substr(7);
    fs::path p(name);
    if (p.is_relative() && relativeToModel) p = mModelDir / p;
    // Symlinks and ".." resolved: a link inside the folder pointing out is outside.
    fs::path real = canonicalOrSelf(p);
    if (!mAllowExternal && real != mModel && !isInside(real, mRoot))
        return errorStatus(ErrorCode::kUnsupported,
                           fmt::format("reference '{}' points outside the model's folder "
                                       "(allow it with --allow-external-refs)",
                                       printable(ref)));
    auto size = checkRegularFile(real.string());
    if (!size)
        return errorStatus(size.status().code(), fmt::format("reference '{}': {}", printable(ref),
                                                             size.status().message()));
    return real;
}

bool ContainedIOSystem::Exists(const char* file) const {
    auto real = mPolicy.resolve(file, false);
    if (!real && !mRefusal && real.status().code() == ErrorCode::kUnsupported)
        mRefusal = real.status();
    return real.isOk();
}

Assimp::IOStream* ContainedIOSystem::Open(const char* file, const char* mode) {
    auto real = mPolicy.resolve(file, false);
    if (!real) {
        // A missing file stays the reader's decision (an OBJ without its .mtl still draws); a
        // file outside the folder, a directory or a FIFO fails the import.
        if (!mRefusal && real.status().code() != ErrorCode::kNotFound) mRefusal = real.status();
        return nullptr;
    }
    return DefaultIOSystem::Open(real->c_str(), mode);
}

}  // namespace plx::scene
