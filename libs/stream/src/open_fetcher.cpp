// The transport factory of `parallax stream walk`: folders get the link simulator, http:// URLs
// the HTTP/1.1 Range fetcher (whose link is the real one: throttle the web server instead).
#include <plx/stream/link_simulator.h>

#include <plx/stream/http_fetch.h>

#include <cmath>

#include <fmt/format.h>

#include <plx/core/file.h>

namespace plx::stream {

Result<std::unique_ptr<Fetcher>> openFetcher(const std::string& location,
                                             const LinkOptions& options) {
    if (!(std::isfinite(options.bandwidthBitsPerS) && options.bandwidthBitsPerS >= 0.0 &&
          std::isfinite(options.latencyS) && options.latencyS >= 0.0))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("link bandwidth {} bit/s and latency {} s must be finite "
                                       "and >= 0",
                                       options.bandwidthBitsPerS, options.latencyS));
    if (location.rfind("http://", 0) == 0) {
        if (options.bandwidthBitsPerS > 0.0 || options.latencyS > 0.0)
            return errorStatus(ErrorCode::kInvalidArgument,
                               "--bandwidth and --latency shape the simulated link of a database "
                               "folder; throttle the web server instead (docs/stream-http.md)");
        return openHttpFetcher(location);
    }
    if (location.rfind("https://", 0) == 0)
        return errorStatus(ErrorCode::kUnsupported,
                           "https is not supported: serve the database over http, or put a TLS "
                           "proxy beside the client");
    if (location.find("://") != std::string::npos)
        return errorStatus(ErrorCode::kUnsupported, location + ": unknown URL scheme");
    if (auto root = checkRegularFile(location + "/root.json"); !root)
        return errorStatus(root.status().code(),
                           location + " is not a stream database: " + root.status().message());
    return std::unique_ptr<Fetcher>(new LinkSimulator(location, options));
}

}  // namespace plx::stream
