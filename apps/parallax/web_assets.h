#pragma once
// The browser client's files (apps/parallax/web: the page, its ES modules), compiled into the
// binary at build time (embed_files.cmake), so that the server serves them from any directory
// and never from the file system.

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

namespace plx::cli {

struct EmbeddedFile {
    std::string_view name;   // the file name in apps/parallax/web ("index.html")
    std::string_view bytes;  // its bytes
};

// Every embedded web file, sorted by name. Defined in the generated web_assets_data.cpp.
std::span<const EmbeddedFile> webFiles();

struct WebAsset {
    std::span<const uint8_t> bytes;
    std::string_view contentType;  // "text/html; charset=utf-8", "text/javascript; ..."
};

// The embedded file a URL path names: "/" (or "") is index.html, "/main.js" is main.js; a query
// or fragment is the caller's to strip. nullopt for every other path: names not embedded,
// folders, "..", backslashes, NUL bytes. No file system lookup happens.
std::optional<WebAsset> webAsset(std::string_view path);

// The Content-Security-Policy served with them: the page runs only its own modules, talks only
// to its own origin (the WebSocket on the same host and port, `?ws=` a path there), loads
// nothing else (its stylesheet and data: icon excepted; no inline script or style) and is never
// framed.
inline constexpr std::string_view kPageSecurityPolicy =
    "default-src 'none'; script-src 'self'; connect-src 'self'; style-src 'self'; "
    "img-src data:; base-uri 'none'; form-action 'none'; frame-ancestors 'none'";

}  // namespace plx::cli
