// The transport factory of `parallax stream walk`: folders get the link simulator. Kept alone in
// this file so that a build with an HTTP transport replaces only this function.
#include <plx/stream/link_simulator.h>

#include <plx/core/file.h>

namespace plx::stream {

Result<std::unique_ptr<Fetcher>> openFetcher(const std::string& location,
                                             const LinkOptions& options) {
    if (location.rfind("http://", 0) == 0 || location.rfind("https://", 0) == 0)
        return errorStatus(ErrorCode::kUnsupported, "http URLs need the HTTP transport");
    if (location.find("://") != std::string::npos)
        return errorStatus(ErrorCode::kUnsupported, location + ": unknown URL scheme");
    if (auto root = checkRegularFile(location + "/root.json"); !root)
        return errorStatus(root.status().code(),
                           location + " is not a stream database: " + root.status().message());
    return std::unique_ptr<Fetcher>(new LinkSimulator(location, options));
}

}  // namespace plx::stream
