// Importing model files through assimp: meshes baked into world space, materials with decoded
// base-colour textures, glTF cameras as viewpoints. Files are untrusted input: every failure
// comes back as a Status naming the file and the problem.

#include <plx/scene/import.h>

#include <array>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <unordered_map>

#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <fmt/format.h>

#include <plx/core/file.h>
#include <plx/scene/generators.h>

#include "contained_io.h"
#include "normals.h"
#include "import_unfinalized.h"
#include "size_check.h"
#include "vertex_join.h"

namespace plx::scene {
namespace {

namespace fs = std::filesystem;

Mat4 toMat4(const aiMatrix4x4& m) {
    // assimp stores row-major matrices with the translation in the fourth column (a4, b4, c4);
    // glm is column-major, so glm's [column][row] is assimp's [row][column].
    Mat4 out;
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) out[c][r] = m[r][c];
    return out;
}

Vec3 toVec3(const aiVector3D& v) { return {v.x, v.y, v.z}; }

Mat4 worldFromNode(const aiNode* node) {
    Mat4 m(1.0f);
    for (const aiNode* n = node; n != nullptr; n = n->mParent) m = toMat4(n->mTransformation) * m;
    return m;
}

// One placement of an assimp mesh in the world (a node referring to it).
struct MeshInstance {
    unsigned meshIndex = 0;
    Mat4 worldFromMesh{1.0f};
    std::string nodeName;
};

// Collects the mesh instances of the node hierarchy. Depth is bounded so that a corrupt file
// with an absurdly deep hierarchy cannot exhaust the stack, and the instance count so that
// instancing cannot multiply a small file into more placements than the limit.
Status collectInstances(const aiScene& ai, const aiNode* node, const Mat4& parentWorld, int depth,
                        size_t maxInstances, std::vector<MeshInstance>* out) {
    constexpr int kMaxDepth = 1024;
    if (depth > kMaxDepth)
        return errorStatus(ErrorCode::kCorruptData,
                           fmt::format("node hierarchy deeper than {}", kMaxDepth));
    Mat4 world = parentWorld * toMat4(node->mTransformation);
    for (unsigned i = 0; i < node->mNumMeshes; ++i) {
        unsigned m = node->mMeshes[i];
        if (m >= ai.mNumMeshes)
            return errorStatus(ErrorCode::kCorruptData,
                               fmt::format("node '{}' refers to missing mesh {}",
                                           printable(node->mName.C_Str()), m));
        if (out->size() >= maxInstances)
            return errorStatus(ErrorCode::kOutOfRange,
                               fmt::format("node instancing places meshes more than the limit of "
                                           "{} times",
                                           maxInstances));
        out->push_back({m, world, node->mName.C_Str()});
    }
    for (unsigned c = 0; c < node->mNumChildren; ++c)
        PLX_RETURN_IF_ERROR(
            collectInstances(ai, node->mChildren[c], world, depth + 1, maxInstances, out));
    return Status::ok();
}

size_t triangleFaceCount(const aiMesh& mesh) {
    size_t n = 0;
    for (unsigned f = 0; f < mesh.mNumFaces; ++f) n += mesh.mFaces[f].mNumIndices == 3 ? 1 : 0;
    return n;
}

// Bakes one mesh instance into world space, keeping only triangles that are not degenerate
// (repeated indices or exactly zero area) and only the vertices they use.
Mesh bakeInstance(const aiMesh& src, const MeshInstance& inst, size_t* degenerate) {
    Mesh out;
    out.name = inst.nodeName.empty() ? src.mName.C_Str()
                                     : inst.nodeName + "/" + src.mName.C_Str();
    out.materialIndex = int(src.mMaterialIndex);
    if (!src.mVertices || !src.mFaces) return out;
    const Mat4& world = inst.worldFromMesh;
    Mat3 linear(world);
    Mat3 normalFromMesh = glm::transpose(glm::inverse(linear));
    bool flip = glm::determinant(linear) < 0.0f;  // mirroring reverses the winding
    bool hasUvs = src.HasTextureCoords(0);

    std::vector<Vec3> worldPos(src.mNumVertices);
    for (unsigned v = 0; v < src.mNumVertices; ++v)
        worldPos[v] = Vec3(world * Vec4(toVec3(src.mVertices[v]), 1.0f));
    // Corners refer to the first of identical vertices (the OBJ reader makes one per corner).
    const std::vector<uint32_t> same = firstIdenticalVertex(src);
    std::vector<Corners> tris;
    tris.reserve(src.mNumFaces);
    for (unsigned f = 0; f < src.mNumFaces; ++f) {
        const aiFace& face = src.mFaces[f];
        if (face.mNumIndices != 3) continue;  // points and lines: not drawable as triangles
        unsigned a = face.mIndices[0], b = face.mIndices[1], c = face.mIndices[2];
        if (a >= src.mNumVertices || b >= src.mNumVertices || c >= src.mNumVertices) continue;
        a = same[a], b = same[b], c = same[c];
        if (flip) std::swap(b, c);
        glm::dvec3 pa(worldPos[a]), pb(worldPos[b]), pc(worldPos[c]);
        glm::dvec3 n = glm::cross(pb - pa, pc - pa);
        // Exactly zero area only: NaN positions compare unequal and go on to finalize(), which
        // rejects them with a message naming the vertex.
        if (a == b || b == c || a == c || glm::dot(n, n) == 0.0) {
            ++*degenerate;
            continue;
        }
        tris.push_back({a, b, c});
    }
    std::vector<Vec3> cornerNormals;
    if (!src.mNormals) cornerNormals = smoothCornerNormals(worldPos, tris);
    // Output vertices: one per source vertex, or per (source vertex, normal) when the normals
    // were generated per corner.
    std::vector<uint32_t> first(src.mNumVertices, UINT32_MAX);
    std::vector<uint32_t> next;  // chains of output vertices made from the same source vertex
    auto emit = [&](unsigned v, const Vec3* cornerNormal) {
        Vec3 n = cornerNormal ? *cornerNormal : normalFromMesh * toVec3(src.mNormals[v]);
        for (uint32_t o = first[v]; o != UINT32_MAX; o = next[o])
            if (!cornerNormal || out.normals[o] == n) return out.indices.push_back(o);
        uint32_t o = uint32_t(out.positions.size());
        out.positions.push_back(worldPos[v]);
        out.normals.push_back(n);
        if (hasUvs) out.uvs.emplace_back(src.mTextureCoords[0][v].x, src.mTextureCoords[0][v].y);
        next.push_back(first[v]);
        first[v] = o;
        out.indices.push_back(o);
    };
    for (size_t t = 0; t < tris.size(); ++t)
        for (int k = 0; k < 3; ++k)
            emit(tris[t][k], cornerNormals.empty() ? nullptr : &cornerNormals[3 * t + k]);
    return out;
}

bool fileExists(const fs::path& p) {
    std::error_code ec;
    return fs::is_regular_file(p, ec);
}

std::string percentDecode(const std::string& s) {
    std::string out;
    for (size_t i = 0; i < s.size(); ++i) {
        if (s[i] == '%' && i + 2 < s.size() && std::isxdigit(uint8_t(s[i + 1])) &&
            std::isxdigit(uint8_t(s[i + 2]))) {
            out.push_back(char(std::stoi(s.substr(i + 1, 2), nullptr, 16)));
            i += 2;
        } else {
            out.push_back(s[i]);
        }
    }
    return out;
}

// A texture that does not decode, whatever the decoder's code: kUnsupported is reserved for
// references outside the model's folder, which fail the import (an unknown image format only
// leaves the material untextured).
Status decodeFailure(const Status& status) {
    return errorStatus(ErrorCode::kCorruptData, status.message());
}

// Decodes an embedded texture: compressed file bytes (PNG/JPEG) or raw BGRA texels.
Result<Image<Rgba8>> decodeEmbedded(const aiTexture& tex, int64_t maxPixels) {
    if (tex.mHeight == 0) {
        auto image = decodeImage(
            std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(tex.pcData), tex.mWidth),
            maxPixels);
        if (!image) return decodeFailure(image.status());
        return toRgba8(*image);
    }
    if (tex.mWidth > unsigned(kMaxDecodedSide) || tex.mHeight > unsigned(kMaxDecodedSide) ||
        int64_t(tex.mWidth) * tex.mHeight > maxPixels)
        return errorStatus(ErrorCode::kOutOfRange,
                           fmt::format("embedded texture of {}x{} texels, more than the limit "
                                       "of {} pixels",
                                       tex.mWidth, tex.mHeight, maxPixels));
    Image<Rgba8> image(int(tex.mWidth), int(tex.mHeight));
    for (size_t i = 0; i < image.pixelCount(); ++i) {
        const aiTexel& t = tex.pcData[i];
        image.data()[i] = Rgba8{t.r, t.g, t.b, t.a};
    }
    return image;
}

// Loads a texture referred to by a material: "*N" or a file name matching an embedded texture,
// else an external file the policy allows (relative to the model's folder). A reference outside
// the folder is kUnsupported (an import error); other failures leave the material untextured.
Result<Image<Rgba8>> loadTextureImage(const aiScene& ai, const RefPolicy& policy,
                                      const std::string& ref, int64_t maxPixels) {
    if (const aiTexture* tex = ai.GetEmbeddedTexture(ref.c_str()))
        return decodeEmbedded(*tex, maxPixels);
    if (!ref.empty() && ref[0] == '*')
        return errorStatus(ErrorCode::kNotFound, "no such embedded texture");
    std::string name = ref;
    std::replace(name.begin(), name.end(), '\\', '/');
    Status firstError;
    for (const std::string& candidate : {name, percentDecode(name)}) {
        auto real = policy.resolve(candidate, true);
        if (real) {
            auto image = readImage(real->string(), maxPixels);
            if (!image) return decodeFailure(image.status());
            return toRgba8(*image);
        }
        if (real.status().code() == ErrorCode::kUnsupported) return real.status();
        if (firstError.isOk()) firstError = real.status();
    }
    return firstError;
}

std::optional<std::string> baseColorTexturePath(const aiMaterial& mat) {
    for (aiTextureType type : {aiTextureType_BASE_COLOR, aiTextureType_DIFFUSE}) {
        aiString path;
        if (mat.GetTextureCount(type) > 0 &&
            mat.GetTexture(type, 0, &path) == AI_SUCCESS && path.length > 0)
            return std::string(path.C_Str());
    }
    return std::nullopt;
}

Vec4 baseColorFactor(const aiMaterial& mat) {
    aiColor4D c(0.8f, 0.8f, 0.8f, 1.0f);
    if (mat.Get(AI_MATKEY_BASE_COLOR, c) == AI_SUCCESS) return {c.r, c.g, c.b, c.a};
    if (mat.Get(AI_MATKEY_COLOR_DIFFUSE, c) != AI_SUCCESS) c = aiColor4D(0.8f, 0.8f, 0.8f, 1.0f);
    float opacity = 1.0f;
    if (mat.Get(AI_MATKEY_OPACITY, opacity) == AI_SUCCESS) c.a *= opacity;
    Vec4 out(c.r, c.g, c.b, c.a);
    for (int i = 0; i < 4; ++i)
        if (!std::isfinite(out[i])) out[i] = 1.0f;
    return glm::clamp(out, Vec4(0.0f), Vec4(1.0f));
}

// Converts the materials; textures shared between materials are decoded once. A texture that
// cannot be loaded is a warning naming it; one outside the model's folder fails the import.
Status convertMaterials(const aiScene& ai, const RefPolicy& policy, const ImportOptions& options,
                        Scene* scene) {
    std::map<std::string, int> textureByRef;
    for (unsigned i = 0; i < ai.mNumMaterials; ++i) {
        const aiMaterial& src = *ai.mMaterials[i];
        Material mat;
        mat.name = src.GetName().C_Str();
        mat.baseColor = baseColorFactor(src);
        auto ref = baseColorTexturePath(src);
        if (ref && options.loadTextures) {
            auto it = textureByRef.find(*ref);
            if (it == textureByRef.end()) {
                int index = -1;
                auto image = loadTextureImage(ai, policy, *ref, options.maxTexturePixels);
                if (image) {
                    Texture tex;
                    tex.name = *ref;
                    tex.mips.push_back(std::move(*image));
                    buildMipChain(&tex);
                    index = int(scene->textures.size());
                    scene->textures.push_back(std::move(tex));
                } else if (image.status().code() == ErrorCode::kUnsupported) {
                    return image.status();
                } else {
                    ++scene->texturesMissing;  // fall back to the base colour
                    scene->warnings.push_back(fmt::format(
                        "texture '{}' not loaded: {}", printable(*ref), image.status().message()));
                }
                it = textureByRef.emplace(*ref, index).first;
            }
            mat.baseColorTexture = it->second;
        }
        scene->materials.push_back(std::move(mat));
    }
    return Status::ok();
}

// glTF cameras (and any other format's cameras) become viewpoints in world space.
void convertCameras(const aiScene& ai, bool isGltf, Scene* scene) {
    for (unsigned i = 0; i < ai.mNumCameras; ++i) {
        const aiCamera& cam = *ai.mCameras[i];
        if (cam.mOrthographicWidth > 0.0f || !(cam.mHorizontalFOV > 0.0f)) continue;
        const aiNode* node = ai.mRootNode ? ai.mRootNode->FindNode(cam.mName) : nullptr;
        Mat4 world = node ? worldFromNode(node) : Mat4(1.0f);
        Viewpoint v;
        v.name = cam.mName.length > 0 ? cam.mName.C_Str() : fmt::format("camera{}", i);
        // assimp 5.2's glTF reader copies the node's translation into mPosition as well, where
        // the node transform already holds it; the glTF camera sits at its node's origin.
        Vec3 localEye = isGltf ? Vec3(0.0f) : toVec3(cam.mPosition);
        v.eyePos = Vec3(world * Vec4(localEye, 1.0f));
        Vec3 viewDir = Mat3(world) * toVec3(cam.mLookAt);
        v.upDir = Mat3(world) * toVec3(cam.mUp);
        float dirLen = glm::length(viewDir), upLen = glm::length(v.upDir);
        // assimp's importers store the full horizontal angle (not the half angle its header
        // promises), except glTF 2.0 in assimp 5.2, which stores yfov * aspectRatio.
        float aspect = cam.mAspect > 0.0f ? cam.mAspect : 1.0f;
        v.fovYDegrees = isGltf ? degrees(cam.mHorizontalFOV / aspect)
                               : degrees(2.0f * std::atan(std::tan(0.5f * cam.mHorizontalFOV) /
                                                          aspect));
        if (!(dirLen > 0.0f) || !(upLen > 0.0f) || !isFinite(v.eyePos) || !isFinite(viewDir) ||
            !(v.fovYDegrees > 0.0f && v.fovYDegrees < 180.0f))
            continue;
        v.targetPos = targetAlong(v.eyePos, viewDir / dirLen);
        v.upDir /= upLen;
        scene->viewpoints.push_back(v);
    }
}

std::string lowerExtension(const std::string& path) {
    std::string ext = fs::path(path).extension().string();
    for (char& ch : ext) ch = char(std::tolower(uint8_t(ch)));
    return ext;
}

bool isGltfPath(const std::string& path) {
    std::string ext = lowerExtension(path);
    return ext == ".gltf" || ext == ".glb";
}

Status convertScene(const aiScene& ai, const std::string& path, const RefPolicy& policy,
                    const ImportOptions& options, Scene* scene) {
    if (!ai.mRootNode) return errorStatus(ErrorCode::kCorruptData, "no node hierarchy");
    std::vector<MeshInstance> instances;
    PLX_RETURN_IF_ERROR(
        collectInstances(ai, ai.mRootNode, Mat4(1.0f), 0, options.maxNodeCopies, &instances));
    // Count before allocating: instancing can multiply a small file into a huge scene.
    size_t triangles = 0, vertices = 0;
    for (const MeshInstance& inst : instances) {
        triangles += triangleFaceCount(*ai.mMeshes[inst.meshIndex]);
        vertices += ai.mMeshes[inst.meshIndex]->mNumVertices;
    }
    if (triangles > options.maxTriangles || vertices > options.maxTriangles)
        return errorStatus(ErrorCode::kOutOfRange,
                           fmt::format("{} triangles and {} vertices after node instancing "
                                       "exceed the limit of {}",
                                       triangles, vertices, options.maxTriangles));
    if (triangles == 0)
        return errorStatus(ErrorCode::kCorruptData,
                           "no triangles (the file holds no faces, or only points or lines)");
    PLX_RETURN_IF_ERROR(convertMaterials(ai, policy, options, scene));
    for (const MeshInstance& inst : instances) {
        Mesh mesh = bakeInstance(*ai.mMeshes[inst.meshIndex], inst,
                                 &scene->degenerateTrianglesDropped);
        if (mesh.materialIndex >= int(scene->materials.size())) mesh.materialIndex = 0;
        if (!mesh.indices.empty()) scene->meshes.push_back(std::move(mesh));
    }
    if (scene->meshes.empty())
        return errorStatus(ErrorCode::kCorruptData,
                           fmt::format("no triangles (all {} are degenerate)", triangles));
    convertCameras(ai, isGltfPath(path), scene);
    return Status::ok();
}

// Recomputes each mesh's primitive-type flags from its faces and checks the face indices.
// Readers given truncated files can leave flags that disagree with the faces, and assimp 5.2's
// triangulation then aborts on an assertion instead of failing; it also reads vertices through
// unchecked indices.
Status repairMeshes(aiScene* ai, size_t maxPolygonCorners) {
    for (unsigned m = 0; m < ai->mNumMeshes; ++m) {
        aiMesh* mesh = ai->mMeshes[m];
        if (!mesh) return errorStatus(ErrorCode::kCorruptData, fmt::format("mesh {} missing", m));
        if (mesh->mNumFaces > 0 && (!mesh->mFaces || !mesh->mVertices))
            return errorStatus(ErrorCode::kCorruptData, fmt::format("mesh {} has no data", m));
        // Non-finite positions are refused here, as finalize() would, because assimp's vertex
        // joining compares positions and merges NaNs away into degenerate faces.
        for (unsigned v = 0; mesh->mVertices && v < mesh->mNumVertices; ++v)
            if (!isFinite(toVec3(mesh->mVertices[v])))
                return errorStatus(ErrorCode::kCorruptData,
                                   fmt::format("mesh {} ('{}'): vertex {} has a non-finite "
                                               "position",
                                               m, printable(mesh->mName.C_Str()), v));
        unsigned types = 0;
        for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
            const aiFace& face = mesh->mFaces[f];
            unsigned n = face.mNumIndices;
            if (n > maxPolygonCorners)
                return errorStatus(ErrorCode::kOutOfRange,
                                   fmt::format("mesh {} face {} has {} corners, more than the "
                                               "limit of {} (triangulation time grows with the "
                                               "square of the corners)",
                                               m, f, n, maxPolygonCorners));
            for (unsigned k = 0; k < n; ++k)
                if (face.mIndices[k] >= mesh->mNumVertices)
                    return errorStatus(ErrorCode::kCorruptData,
                                       fmt::format("mesh {} face {} refers to vertex {} of {}", m,
                                                   f, face.mIndices[k], mesh->mNumVertices));
            if (n == 0) continue;
            types |= n == 1   ? aiPrimitiveType_POINT
                     : n == 2 ? aiPrimitiveType_LINE
                     : n == 3 ? aiPrimitiveType_TRIANGLE
                              : aiPrimitiveType_POLYGON;
        }
        // Only empty faces (a reader that allocated faces it never read): flag them as points,
        // since flags of 0 make the triangulation assert on them.
        if (types == 0 && mesh->mNumFaces > 0) types = aiPrimitiveType_POINT;
        mesh->mPrimitiveTypes = types;
    }
    return Status::ok();
}

// assimp's readers quote the bytes they choke on ("Invalid base64 encoded data: \"...\""):
// quoted text other than the file's own path is elided, so no message shows file content.
// One line, at most 200 characters.
std::string withoutQuotedContent(const std::string& message, const std::string& path) {
    std::string out;
    for (size_t i = 0; i < message.size() && out.size() < 200; ++i) {
        size_t close = message[i] == '"' ? message.find('"', i + 1) : std::string::npos;
        if (close != std::string::npos) {
            std::string quoted = message.substr(i + 1, close - i - 1);
            out += quoted == path ? '"' + quoted + '"' : std::string("(quoted content elided)");
            i = close;
        } else {
            out.push_back(message[i] == '\n' || message[i] == '\r' ? ' ' : message[i]);
        }
    }
    return out;
}

// A reader that asked for more memory than there is; the isolated import maps "out of memory" to
// its memory limit.
Status outOfMemory() {
    return errorStatus(ErrorCode::kOutOfRange,
                       "out of memory while reading the file (its contents ask for more than "
                       "this machine has)");
}

// Counts declared in the file against its size and the limits, before assimp allocates.
Status checkFile(const std::string& path, uint64_t size, const ImportOptions& options) {
    if (size == 0) return errorStatus(ErrorCode::kCorruptData, "file is empty");
    std::string ext = lowerExtension(path);
    if (ext == ".ply") return checkPlyCounts(path, size, options.maxTriangles);
    if (ext == ".obj") return checkObjCounts(path, options.maxTriangles);
    if (ext == ".off") return checkOffFile(path, size, options.maxTriangles);
    if (ext == ".x") return checkXFaces(path, size);
    if (ext == ".smd") return checkSmdSections(path);
    if (ext == ".ac" || ext == ".acc" || ext == ".ac3d")
        return checkAc3dSubdivision(
            path, std::min(options.maxTriangles, options.maxSubdividedTriangles));
    if (ext == ".gltf" || ext == ".glb")
        return checkGltfExpansion(path, size, options.maxNodeCopies, options.maxTriangles);
    return Status::ok();
}

}  // namespace

Result<Scene> importFile(const std::string& path, const ImportOptions& options) {
    if (options.isolation.enabled) return importFileIsolated(path, options);
    auto scene = importFileUnfinalized(path, options);
    if (!scene) return scene.status();
    Status finalized = scene->finalize();
    if (!finalized) return errorStatus(finalized.code(), path + ": " + finalized.message());
    return scene;
}

Result<Scene> importFileUnfinalized(const std::string& path, const ImportOptions& options) {
    auto named = [&](const Status& s) { return errorStatus(s.code(), path + ": " + s.message()); };
    // A directory, FIFO or device is refused here, without blocking; the message names the path
    // and the cause (not found, symlink loop, permission).
    auto size = checkRegularFile(path);
    if (!size) return size.status();
    Status precheck = checkFile(path, *size, options);
    if (!precheck) return named(precheck);

    Assimp::Importer importer;
    RefPolicy policy(path, options.allowExternalRefs);
    auto* io = new ContainedIOSystem(policy);  // owned by the importer
    importer.SetIOHandler(io);
    // Two passes: read, then repair what the readers can get wrong on truncated input, then
    // post-process. Normals missing from the file are made in bakeInstance (assimp's smoothing
    // ignores its angle limit on shared vertices); validation is ours too (assimp's validator
    // refuses point-only meshes, which we report as "no triangles").
    const aiScene* ai = nullptr;
    try {
        ai = importer.ReadFile(path, 0);
        if (ai) {
            Status repaired = repairMeshes(const_cast<aiScene*>(ai), options.maxPolygonCorners);
            if (!repaired) return named(repaired);
            // UV (0,0) is the top-left texel, as in glTF and in plx::Image.
            // Identical vertices are joined in bakeInstance (vertex_join.h), in linear time.
            ai = importer.ApplyPostProcessing(aiProcess_Triangulate | aiProcess_FlipUVs);
        }
    } catch (const std::bad_alloc&) {  // assimp catches its own errors, not this one
        return named(outOfMemory());
    } catch (const std::exception&) {  // what() may quote the file: not shown
        return named(errorStatus(ErrorCode::kCorruptData, "assimp failed while reading the file"));
    }
    // Readers shrug off a file they cannot open (an OBJ's material library); a reference that
    // was refused fails the import whatever the reader made of it.
    if (io->firstRefusal()) return named(*io->firstRefusal());
    if (!ai) {
        // Some readers catch std::bad_alloc themselves and report its what() as their error.
        if (std::strstr(importer.GetErrorString(), "bad_alloc")) return named(outOfMemory());
        std::string why = withoutQuotedContent(importer.GetErrorString(), path);
        if (why.empty()) why = "assimp could not read the file";
        return named(errorStatus(ErrorCode::kCorruptData, why));
    }
    Scene scene;
    Status converted = convertScene(*ai, path, policy, options, &scene);
    if (!converted) return named(converted);
    return scene;
}

bool isGeneratorSpec(const std::string& spec) {
    size_t colon = spec.find(':');
    if (colon == std::string::npos) return isCountFreeGenerator(spec) && !fileExists(spec);
    if (colon == 0) return false;
    for (size_t i = 0; i < colon; ++i)
        if (!std::isalpha(uint8_t(spec[i])) && spec[i] != '_') return false;
    // "C:/models/x.obj" and "name:arg/with/slashes" are paths, never specs.
    if (spec.find_first_of("/\\", colon) != std::string::npos) return false;
    return !fileExists(spec);
}

Result<Scene> loadScene(const std::string& spec, const ImportOptions& options) {
    if (isGeneratorSpec(spec)) return generateFromSpec(spec);
    return importFile(spec, options);
}

}  // namespace plx::scene
