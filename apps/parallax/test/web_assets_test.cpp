// The embedded web files: every file of apps/parallax/web is served by its URL path with its
// bytes and content type, and nothing else is: no folders, no "..", no file system.
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>

#include "web_assets.h"

namespace plx::cli {
namespace {

std::string fileBytes(const std::filesystem::path& p) {
    std::ifstream f(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(f), {}};
}

std::string assetBytes(const WebAsset& a) {
    return {reinterpret_cast<const char*>(a.bytes.data()), a.bytes.size()};
}

TEST(WebAssets, EveryWebFileIsEmbeddedByteForByte) {
    namespace fs = std::filesystem;
    const fs::path dir = fs::path(PLX_SOURCE_DIR) / "apps/parallax/web";
    int count = 0;
    for (const auto& e : fs::directory_iterator(dir)) {
        const std::string name = e.path().filename().string();
        const auto asset = webAsset("/" + name);
        ASSERT_TRUE(asset) << name;
        EXPECT_EQ(assetBytes(*asset), fileBytes(e.path())) << name;
        ++count;
    }
    EXPECT_EQ(size_t(count), webFiles().size());
    EXPECT_GE(count, 2);
}

TEST(WebAssets, RootIsThePageAndTypesFollowTheName) {
    const auto root = webAsset("/");
    ASSERT_TRUE(root);
    EXPECT_EQ(root->contentType, "text/html; charset=utf-8");
    EXPECT_EQ(assetBytes(*root), assetBytes(*webAsset("/index.html")));
    EXPECT_EQ(assetBytes(*webAsset("")), assetBytes(*root));
    ASSERT_TRUE(webAsset("/main.js"));
    EXPECT_EQ(webAsset("/main.js")->contentType, "text/javascript; charset=utf-8");
    ASSERT_TRUE(webAsset("/page.css"));
    EXPECT_EQ(webAsset("/page.css")->contentType, "text/css; charset=utf-8");
}

TEST(WebAssets, RefusesEverythingElse) {
    for (std::string_view path :
         {"main.js", "/../CMakeLists.txt", "/..", "/web/main.js", "/./main.js", "//main.js",
          "/main.js/", "/..\\main.js", "/missing.js", "/index.html.bak", "/.."}) {
        EXPECT_FALSE(webAsset(path)) << path;
    }
    EXPECT_FALSE(webAsset(std::string_view("/main.js\0.png", 13)));
    EXPECT_FALSE(webAsset("/etc/passwd"));
}

}  // namespace
}  // namespace plx::cli
