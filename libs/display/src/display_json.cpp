// Display description files.

#include <plx/display/display_json.h>

#include <plx/core/file.h>

#include <cmath>
#include <optional>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <plx/core/image_io.h>

namespace plx::display {
namespace {

using nlohmann::json;

Status fieldError(const std::string& path, const std::string& problem) {
    return errorStatus(ErrorCode::kCorruptData, path + ": " + problem);
}

// The largest length a description may give, in mm (10 km): the display becomes float scene and
// camera coordinates, which still step by a millimetre there, and far larger values (1e39 mm)
// are no float at all.
constexpr double kMaxLengthMm = 1e7;

// The largest framebuffer or projector side, in pixels, and the rule as messages state it.
constexpr int64_t kMaxPixelSide = 16384;
constexpr const char* kPixelSideRule = "pixel sizes must lie in [1, 16384]";

// A field and what is wrong with it: the checks that parsing and validateDisplay share.
struct Problem {
    const char* path;
    const char* text;
};

std::optional<Problem> sheetProblem(const ConeMirror& cone) {
    if (!(cone.sheetThicknessMm >= 0.0))
        return Problem{"optics.sheet.thickness", "must not be negative"};
    if (!(cone.refractiveIndex >= 1.0 && cone.refractiveIndex <= 4.0))
        return Problem{"optics.sheet.refractive_index", "must lie in [1, 4]"};
    return std::nullopt;
}

std::optional<Problem> projectorProblem(const Projector& p) {
    if (!(p.fovYDegrees > 1.0 && p.fovYDegrees < 170.0))
        return Problem{"optics.projector.fov_y", "must lie in (1, 170) degrees"};
    DVec3 f = p.targetMm - p.posMm;
    if (!(glm::length(f) >= 1e-9)) return Problem{"optics.projector", "target equals position"};
    if (!(glm::length(glm::cross(f, p.upDir)) >= 1e-9 * glm::length(f)))
        return Problem{"optics.projector.up", "must not be parallel to the view direction"};
    return std::nullopt;
}

bool pixelSizeFits(int64_t width, int64_t height) {
    return width >= 1 && height >= 1 && width <= kMaxPixelSide && height <= kMaxPixelSide;
}

// Small typed accessors that name the field on failure.
class Reader {
public:
    explicit Reader(double scale) : mScale(scale) {}

    Status object(const json& parent, const std::string& key, const std::string& path,
                  const json** out) const {
        auto it = parent.find(key);
        if (it == parent.end()) return fieldError(path, "missing");
        if (!it->is_object()) return fieldError(path, "must be an object");
        *out = &*it;
        return Status::ok();
    }
    Status number(const json& parent, const std::string& key, const std::string& path,
                  double* out, bool length) const {
        auto it = parent.find(key);
        if (it == parent.end()) return fieldError(path, "missing");
        if (!it->is_number()) return fieldError(path, "must be a number");
        return store(it->get<double>(), length, path, out);
    }
    Status positive(const json& parent, const std::string& key, const std::string& path,
                    double* out) const {
        PLX_RETURN_IF_ERROR(number(parent, key, path, out, true));
        if (*out <= 0.0) return fieldError(path, "must be a positive number");
        return Status::ok();
    }
    Status vec3(const json& parent, const std::string& key, const std::string& path, DVec3* out,
                bool length) const {
        auto it = parent.find(key);
        if (it == parent.end()) return fieldError(path, "missing");
        if (!it->is_array() || it->size() != 3) return fieldError(path, "must be [x, y, z]");
        for (int i = 0; i < 3; ++i) {
            if (!(*it)[i].is_number()) return fieldError(path, "must hold three numbers");
            PLX_RETURN_IF_ERROR(store((*it)[i].get<double>(), length, path, &(*out)[i]));
        }
        return Status::ok();
    }
    Status vec2(const json& parent, const std::string& key, const std::string& path,
                DVec2* out) const {
        auto it = parent.find(key);
        if (it == parent.end()) return fieldError(path, "missing");
        if (!it->is_array() || it->size() != 2) return fieldError(path, "must be [a, b]");
        for (int i = 0; i < 2; ++i) {
            if (!(*it)[i].is_number()) return fieldError(path, "must hold two numbers");
            PLX_RETURN_IF_ERROR(store((*it)[i].get<double>(), true, path, &(*out)[i]));
        }
        return Status::ok();
    }
    Status size(const json& parent, const std::string& key, const std::string& path, int* w,
                int* h) const {
        auto it = parent.find(key);
        if (it == parent.end()) return fieldError(path, "missing");
        if (!it->is_array() || it->size() != 2 || !(*it)[0].is_number_integer() ||
            !(*it)[1].is_number_integer())
            return fieldError(path, "must be [width, height] in whole pixels");
        int64_t a = (*it)[0].get<int64_t>(), b = (*it)[1].get<int64_t>();
        if (!pixelSizeFits(a, b)) return fieldError(path, kPixelSideRule);
        *w = int(a), *h = int(b);
        return Status::ok();
    }

private:
    // A finite number as the display holds it: a length in mm, within kMaxLengthMm.
    Status store(double v, bool length, const std::string& path, double* out) const {
        if (!std::isfinite(v)) return fieldError(path, "must be finite");
        *out = length ? v * mScale : v;
        if (length && !(std::fabs(*out) <= kMaxLengthMm))
            return fieldError(path, fmt::format("must lie within +-{:g} mm", kMaxLengthMm));
        return Status::ok();
    }

    double mScale;
};

Status parseSheet(const Reader& rd, const json& optics, ConeMirror* cone) {
    auto it = optics.find("sheet");
    if (it == optics.end()) return Status::ok();
    if (!it->is_object()) return fieldError("optics.sheet", "must be an object");
    PLX_RETURN_IF_ERROR(
        rd.number(*it, "thickness", "optics.sheet.thickness", &cone->sheetThicknessMm, true));
    PLX_RETURN_IF_ERROR(rd.number(*it, "refractive_index", "optics.sheet.refractive_index",
                                  &cone->refractiveIndex, false));
    if (auto problem = sheetProblem(*cone)) return fieldError(problem->path, problem->text);
    return Status::ok();
}

Status parseProjector(const Reader& rd, const json& optics, Projector* p) {
    const json* pj;
    PLX_RETURN_IF_ERROR(rd.object(optics, "projector", "optics.projector", &pj));
    PLX_RETURN_IF_ERROR(rd.vec3(*pj, "position", "optics.projector.position", &p->posMm, true));
    PLX_RETURN_IF_ERROR(rd.vec3(*pj, "target", "optics.projector.target", &p->targetMm, true));
    if (pj->contains("up"))
        PLX_RETURN_IF_ERROR(rd.vec3(*pj, "up", "optics.projector.up", &p->upDir, false));
    PLX_RETURN_IF_ERROR(rd.number(*pj, "fov_y", "optics.projector.fov_y", &p->fovYDegrees, false));
    PLX_RETURN_IF_ERROR(
        rd.size(*pj, "resolution", "optics.projector.resolution", &p->widthPx, &p->heightPx));
    if (auto problem = projectorProblem(*p)) return fieldError(problem->path, problem->text);
    return Status::ok();
}

Status parseOptics(const Reader& rd, const json& root, Display* d) {
    const json* oj;
    PLX_RETURN_IF_ERROR(rd.object(root, "optics", "optics", &oj));
    auto typeIt = oj->find("type");
    if (typeIt == oj->end()) return fieldError("optics.type", "missing");
    if (!typeIt->is_string()) return fieldError("optics.type", "must be a string");
    std::string type = typeIt->get<std::string>();
    if (type == "cone_mirror" || type == "cylinder_mirror") {
        ConeMirror cone;
        if (type == "cone_mirror") {
            PLX_RETURN_IF_ERROR(rd.positive(*oj, "bottom_radius", "optics.bottom_radius",
                                            &cone.bottomRadiusMm));
            PLX_RETURN_IF_ERROR(
                rd.positive(*oj, "top_radius", "optics.top_radius", &cone.topRadiusMm));
            if (cone.topRadiusMm <= cone.bottomRadiusMm)
                return fieldError("optics.top_radius",
                                  "must exceed bottom_radius (the display lies below the cone)");
        } else {
            PLX_RETURN_IF_ERROR(rd.positive(*oj, "radius", "optics.radius", &cone.bottomRadiusMm));
            cone.topRadiusMm = cone.bottomRadiusMm;
        }
        PLX_RETURN_IF_ERROR(rd.positive(*oj, "height", "optics.height", &cone.heightMm));
        PLX_RETURN_IF_ERROR(parseSheet(rd, *oj, &cone));
        d->optics = cone;
        return Status::ok();
    }
    if (type == "cylinder_screen" || type == "dome_screen") {
        ProjectedScreen screen;
        DVec3 centre;
        double radius;
        PLX_RETURN_IF_ERROR(rd.vec3(*oj, "center", "optics.center", &centre, true));
        PLX_RETURN_IF_ERROR(rd.positive(*oj, "radius", "optics.radius", &radius));
        if (type == "cylinder_screen") screen.surface = CylinderScreen{centre, radius};
        else screen.surface = DomeScreen{centre, radius};
        PLX_RETURN_IF_ERROR(parseProjector(rd, *oj, &screen.projector));
        d->optics = screen;
        d->displayMin = {0.0, 0.0};
        d->displayMax = {double(screen.projector.widthPx), double(screen.projector.heightPx)};
        d->framebufferWidth = screen.projector.widthPx;
        d->framebufferHeight = screen.projector.heightPx;
        return Status::ok();
    }
    return fieldError("optics.type", "unknown type '" + printable(type) +
                                         "' (expected cone_mirror, cylinder_mirror, "
                                         "cylinder_screen or dome_screen)");
}

bool insideScreen(const ProjectedScreen& s, const DVec3& p) {
    if (const auto* c = std::get_if<CylinderScreen>(&s.surface)) {
        DVec2 q(p.x - c->centerMm.x, p.z - c->centerMm.z);
        return glm::length(q) < c->radiusMm;
    }
    const auto& dome = std::get<DomeScreen>(s.surface);
    return glm::length(p - dome.centerMm) < dome.radiusMm;
}

}  // namespace

Status validateDisplay(const Display& d) {
    auto bad = [](const std::string& m) { return errorStatus(ErrorCode::kInvalidArgument, m); };
    if (!(d.contentRadiusMm > 0.0) || !std::isfinite(d.contentRadiusMm))
        return bad("content.radius: must be a positive number");
    double toCentre = glm::length(d.defaultViewerMm - d.contentCenterMm);
    if (!(toCentre > 1.05 * d.contentRadiusMm))
        return bad("viewer: must lie outside the content sphere");
    if (!(d.displayMax.x > d.displayMin.x && d.displayMax.y > d.displayMin.y))
        return bad("display: max must exceed min on both axes");
    auto badField = [&](const Problem& p) { return bad(std::string(p.path) + ": " + p.text); };
    if (!pixelSizeFits(d.framebufferWidth, d.framebufferHeight))
        return badField({"display.framebuffer", kPixelSideRule});
    if (const auto* cone = std::get_if<ConeMirror>(&d.optics)) {
        if (!(cone->bottomRadiusMm > 0.0 && cone->topRadiusMm >= cone->bottomRadiusMm &&
              cone->heightMm > 0.0))
            return bad(
                "optics: the mirror needs positive radii, top no smaller than bottom, "
                "and a positive height");
        if (auto problem = sheetProblem(*cone)) return badField(*problem);
        const DVec3& e = d.defaultViewerMm;
        double r = cone->bottomRadiusMm + cone->slope() * e.y;
        if (std::hypot(e.x, e.z) <= r) return bad("viewer: must lie outside the mirror");
    } else {
        const auto& screen = std::get<ProjectedScreen>(d.optics);
        if (!pixelSizeFits(screen.projector.widthPx, screen.projector.heightPx))
            return badField({"optics.projector.resolution", kPixelSideRule});
        if (auto problem = projectorProblem(screen.projector)) return badField(*problem);
        if (!insideScreen(screen, d.defaultViewerMm))
            return bad("viewer: must lie inside the screen");
        if (!insideScreen(screen, screen.projector.posMm))
            return bad("optics.projector.position: must lie inside the screen");
    }
    return Status::ok();
}

Result<Display> parseDisplayJson(std::string_view text) {
    json root;
    try {
        root = json::parse(text);
    } catch (const json::parse_error& e) {
        // e.byte is 1-based and points just past the offending character; e.what() would
        // quote the text, so only the position is given.
        return errorStatus(ErrorCode::kCorruptData,
                           fmt::format("not valid JSON at {} (NaN and Infinity are not JSON "
                                       "numbers either)",
                                       lineColumn(text, e.byte > 0 ? e.byte - 1 : 0)));
    } catch (const json::exception&) {  // a number out of range (1e999): no position kept
        return errorStatus(ErrorCode::kCorruptData,
                           "not valid JSON (a number out of range; NaN "
                           "and Infinity are not JSON numbers either)");
    }
    if (!root.is_object()) return fieldError("document", "must be a JSON object");
    double scale = 1.0;
    if (auto it = root.find("units"); it != root.end()) {
        if (!it->is_string()) return fieldError("units", "must be a string");
        std::string u = it->get<std::string>();
        if (u == "mm") scale = 1.0;
        else if (u == "cm") scale = 10.0;
        else if (u == "m") scale = 1000.0;
        else
            return fieldError("units",
                              "unknown unit '" + printable(u) + "' (expected mm, cm or m)");
    }
    Reader rd(scale);
    Display d;
    if (auto it = root.find("name"); it != root.end()) {
        if (!it->is_string()) return fieldError("name", "must be a string");
        d.name = it->get<std::string>();
    }
    PLX_RETURN_IF_ERROR(parseOptics(rd, root, &d));
    if (std::holds_alternative<ConeMirror>(d.optics) || root.contains("display")) {
        const json* dj;
        PLX_RETURN_IF_ERROR(rd.object(root, "display", "display", &dj));
        PLX_RETURN_IF_ERROR(rd.vec2(*dj, "min", "display.min", &d.displayMin));
        PLX_RETURN_IF_ERROR(rd.vec2(*dj, "max", "display.max", &d.displayMax));
        PLX_RETURN_IF_ERROR(rd.size(*dj, "framebuffer", "display.framebuffer",
                                    &d.framebufferWidth, &d.framebufferHeight));
    }
    PLX_RETURN_IF_ERROR(rd.vec3(root, "viewer", "viewer", &d.defaultViewerMm, true));
    const json* cj;
    PLX_RETURN_IF_ERROR(rd.object(root, "content", "content", &cj));
    PLX_RETURN_IF_ERROR(rd.vec3(*cj, "center", "content.center", &d.contentCenterMm, true));
    PLX_RETURN_IF_ERROR(rd.positive(*cj, "radius", "content.radius", &d.contentRadiusMm));
    PLX_RETURN_IF_ERROR(validateDisplay(d));
    return d;
}

Result<Display> loadDisplayFile(const std::string& path) {
    auto bytes = readFileBytes(path);
    if (!bytes) return bytes.status();  // already names the path
    auto display = parseDisplayJson(
        std::string_view(reinterpret_cast<const char*>(bytes->data()), bytes->size()));
    if (!display) return Status(display.status().code(), path + ": " + display.status().message());
    return display;
}

}  // namespace plx::display
