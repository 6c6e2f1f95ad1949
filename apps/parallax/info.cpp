// parallax info SCENE: what a scene holds (meshes, triangles, materials, textures, bounds,
// viewpoints).

#include <fmt/format.h>

#include <plx/core/cpu.h>
#include <plx/scene/import.h>

#include "commands.h"
#include "view.h"

namespace plx::cli {

Command registerInfo(CLI::App& app) {
    struct Args {
        std::string scene;
        bool json = false;
    };
    auto args = std::make_shared<Args>();
    CLI::App* sub = app.add_subcommand("info", "Print what a scene holds");
    sub->footer("Example: parallax info office:4 --json");
    sub->add_option("scene", args->scene, "Model file or generator spec (office:N, museum:N)")
        ->required();
    sub->add_flag("--json", args->json, "Machine-readable output on stdout");
    return {sub, [args]() -> int {
                auto scene = loadSceneChecked(args->scene);
                if (!scene) return fail(scene.status());
                scene::SceneStats s = scene->stats();
                nlohmann::json doc = {
                    {"scene", args->scene},
                    {"meshes", s.meshes},
                    {"vertices", s.vertices},
                    {"triangles", s.triangles},
                    {"materials", s.materials},
                    {"textures", s.textures},
                    {"texture_bytes", s.textureBytes},
                    {"textures_failed", s.texturesMissing},
                    {"degenerate_triangles_dropped", s.degenerateTrianglesDropped},
                    {"bounds_min", {s.bounds.lo.x, s.bounds.lo.y, s.bounds.lo.z}},
                    {"bounds_max", {s.bounds.hi.x, s.bounds.hi.y, s.bounds.hi.z}},
                };
                nlohmann::json views = nlohmann::json::array();
                for (const auto& v : scene->viewpoints) views.push_back(v.name);
                doc["viewpoints"] = views;
                doc["kernels"] = std::string(isaName(activeIsa()));
                doc["kernels_runnable"] = nlohmann::json::array();
                for (Isa isa : runnableIsas())
                    doc["kernels_runnable"].push_back(std::string(isaName(isa)));
                if (args->json) {
                    printJson(doc);
                } else {
                    fmt::print("{}: {}, {}, {}, {}, {} ({:.1f} MiB with mips){}\n", args->scene,
                               counted(s.meshes, "mesh"), counted(s.vertices, "vertex"),
                               counted(s.triangles, "triangle"), counted(s.materials, "material"),
                               counted(s.textures, "texture"), double(s.textureBytes) / (1 << 20),
                               s.texturesMissing > 0
                                   ? fmt::format(", {} failed to load", s.texturesMissing)
                                   : "");
                    fmt::print("bounds: ({:.3g}, {:.3g}, {:.3g}) .. ({:.3g}, {:.3g}, {:.3g})\n",
                               s.bounds.lo.x, s.bounds.lo.y, s.bounds.lo.z, s.bounds.hi.x,
                               s.bounds.hi.y, s.bounds.hi.z);
                    for (const auto& v : scene->viewpoints) fmt::print("viewpoint: {}\n", v.name);
                    fmt::print("{}\n", isaSummary());
                }
                return kExitOk;
            }};
}

}  // namespace plx::cli
