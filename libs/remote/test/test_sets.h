#pragma once
// Small rendered reference sets shared by the remote tests (rendered once per process).

#include <memory>
#include <string>

#include <gtest/gtest.h>

#include <plx/raster/raster.h>
#include <plx/scene/generators.h>
#include <plx/warp/reference.h>

namespace plx::remote {

// A cube4 set of `spec` (office:1, museum:1) at its first viewpoint with the given face size.
inline const warp::ReferenceSet& renderedSet(const std::string& spec, int face) {
    static std::map<std::string, std::unique_ptr<warp::ReferenceSet>> sets;
    auto& slot = sets[spec + "/" + std::to_string(face)];
    if (!slot) {
        const scene::Scene scene = *scene::generateFromSpec(spec);
        auto renderer = std::move(raster::Renderer::create({2})).value();
        warp::ReferenceSetOptions o;
        o.faceSize = face;
        slot = std::make_unique<warp::ReferenceSet>();
        EXPECT_TRUE(warp::renderReferenceSet(*renderer, scene,
                                             warp::poseAt(scene.viewpoints.front()), o, slot.get())
                        .isOk());
    }
    return *slot;
}

inline void expectOneLineError(const Status& status, const std::string& word = {}) {
    EXPECT_FALSE(status.isOk());
    EXPECT_FALSE(status.message().empty());
    EXPECT_EQ(status.message().find('\n'), std::string::npos) << status.message();
    EXPECT_NE(status.message().find(word), std::string::npos) << status.message();
}

}  // namespace plx::remote
