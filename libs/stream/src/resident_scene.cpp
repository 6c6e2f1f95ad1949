// The scene the renderer draws (Marvie & Bouatouch section 6, the display step): the downloaded
// geometry of the current cell's PVS with each texture at its highest resident level only.
#include <plx/stream/client.h>

namespace plx::stream {
namespace {

// Not-yet-resident textures draw in this flat linear grey (neither black nor white, so missing
// levels read as "loading" rather than as a material).
constexpr float kMissingGrey = 0.5f;

}  // namespace

Result<scene::Scene> StreamClient::residentScene(
    const std::map<std::string, scene::Texture>* fullTextures) {
    scene::Scene out;
    if (mCurrentCell < 0 || !mCells[size_t(mCurrentCell)].file)
        return errorStatus(ErrorCode::kNotFound, "no cell downloaded yet");
    // Each texture goes into the scene once, however many primitives use it.
    std::map<const scene::Texture*, int> slotOf;
    auto slot = [&](const scene::Texture& t) {
        auto [it, added] = slotOf.emplace(&t, int(out.textures.size()));
        if (added) out.textures.push_back(t);
        return it->second;
    };
    for (const PvsUrlEntry& e : mCells[size_t(mCurrentCell)].file->pvs) {
        auto idx = cellIndexOfUrl(e.url, mRoot->cells);
        if (!idx) continue;
        for (const GlbPrimitive& p : mCells[*idx].primitives) {
            if (p.indices.empty()) continue;
            scene::Material m;
            m.baseColor = p.baseColor;
            if (!p.ptmUrl.empty()) m.baseColor = Vec4(Vec3(kMissingGrey), 1.0f);
            const bool hasUvs = p.uvs.size() == p.positions.size();
            auto node = mNodeOfUrl.find(p.ptmUrl);
            const scene::Texture* full = nullptr;
            if (fullTextures)
                if (auto it = fullTextures->find(p.ptmUrl); it != fullTextures->end())
                    full = &it->second;
            if (hasUvs && full) {
                m.baseColor = Vec4(1.0f);
                m.baseColorTexture = slot(*full);
            } else if (hasUvs && node != mNodeOfUrl.end() &&
                       mNodes[size_t(node->second)].resident > 0) {
                int n = node->second, r = mNodes[size_t(n)].resident;
                CachedTexture& cached = mTextureCache[n];
                if (cached.resident != r) {
                    // The highest resident level as the base, its smaller levels rebuilt by the
                    // scene's filter (the same chain the resident PTM levels hold).
                    cached.texture = {};
                    cached.texture.mips.push_back(toRgba8(mDecoders[size_t(n)]->level(r - 1)));
                    scene::buildMipChain(&cached.texture);
                    cached.resident = r;
                }
                m.baseColor = Vec4(1.0f);
                m.baseColorTexture = slot(cached.texture);
            }
            scene::Mesh mesh;
            mesh.positions = p.positions;
            if (m.baseColorTexture >= 0) mesh.uvs = p.uvs;
            mesh.indices = p.indices;
            mesh.materialIndex = int(out.materials.size());
            out.materials.push_back(std::move(m));
            out.meshes.push_back(std::move(mesh));
        }
    }
    if (out.meshes.empty()) return errorStatus(ErrorCode::kNotFound, "no geometry downloaded yet");
    PLX_RETURN_IF_ERROR(out.finalize());
    return out;
}

}  // namespace plx::stream
