// Lookup of the embedded web files by URL path (web_assets.h).

#include "web_assets.h"

#include <algorithm>

namespace plx::cli {
namespace {

std::string_view contentType(std::string_view name) {
    const auto endsWith = [&](std::string_view s) {
        return name.size() >= s.size() && name.substr(name.size() - s.size()) == s;
    };
    if (endsWith(".html")) return "text/html; charset=utf-8";
    if (endsWith(".js")) return "text/javascript; charset=utf-8";
    if (endsWith(".css")) return "text/css; charset=utf-8";
    return "application/octet-stream";
}

}  // namespace

std::optional<WebAsset> webAsset(std::string_view path) {
    if (path.empty() || path == "/") path = "/index.html";
    if (path.front() != '/') return std::nullopt;
    path.remove_prefix(1);
    // Only flat names of embedded files: nothing that could mean another folder.
    if (path.find_first_of(std::string_view("/\\\0", 3)) != std::string_view::npos ||
        path.find("..") != std::string_view::npos) {
        return std::nullopt;
    }
    const std::span<const EmbeddedFile> files = webFiles();
    const auto it = std::find_if(files.begin(), files.end(),
                                 [&](const EmbeddedFile& f) { return f.name == path; });
    if (it == files.end()) return std::nullopt;
    return WebAsset{{reinterpret_cast<const uint8_t*>(it->bytes.data()), it->bytes.size()},
                    contentType(it->name)};
}

}  // namespace plx::cli
