#pragma once
// How the streaming client gets the database's bytes (Marvie & Bouatouch section 6: "requests
// ... are sent to the server"): asynchronous requests for a whole file or one byte range of it
// (a PTM level group, by the PTM level index; docs/ptm-format.md), completed over time by a
// transport. Implementations: a deterministic link simulator over a local database folder
// (experiments and tests) and HTTP/1.1 with Range requests against any web server.
//
// Every completion's bytes are untrusted: the client checks length, format and content.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <plx/core/status.h>

namespace plx::stream {

// Bytes first..last of a file, inclusive, as in an HTTP Range header.
struct ByteRange {
    uint64_t first = 0;
    uint64_t last = 0;
    uint64_t size() const { return last - first + 1; }
    friend bool operator==(const ByteRange&, const ByteRange&) = default;
};

// "PATH" or "PATH bytes FIRST-LAST": how every message about a request names it.
inline std::string describeRequest(const std::string& path, const std::optional<ByteRange>& range) {
    if (!range) return path;
    return path + " bytes " + std::to_string(range->first) + "-" + std::to_string(range->last);
}

struct FetchRequest {
    uint64_t id = 0;                 // chosen by the caller, echoed by the completion
    std::string path;                // relative to the database root; checkUrl holds
    std::optional<ByteRange> range;  // none: the whole file
    uint64_t maxBytes = 0;           // the most bytes the caller accepts (a larger body fails)
};

struct FetchCompletion {
    uint64_t id = 0;
    Status status;               // ok, or one line naming the path and what went wrong
    std::vector<uint8_t> bytes;  // the body when ok (exactly range->size() for a range request)
    double submittedAtS = 0.0;   // on the fetcher's clock, seconds
    double finishedAtS = 0.0;
};

// One transport. Requests complete in the order they were submitted (one link, FIFO), which the
// client's scheduling relies on (cells and geometry before texture levels).
class Fetcher {
public:
    virtual ~Fetcher() = default;
    // Queues a request at time nowS (the caller's clock: simulated for the simulator, seconds
    // since the walk began for HTTP).
    virtual void submit(FetchRequest request, double nowS) = 0;
    // The completions finished at or before nowS, in completion order. A simulator advances its
    // link to nowS; a real transport returns what has arrived (it never blocks).
    virtual std::vector<FetchCompletion> poll(double nowS) = 0;
    // Requests submitted and not yet returned by poll.
    virtual size_t pending() const = 0;
    // True for a real transport, whose requests complete in wall-clock time: a caller that runs
    // on a simulated clock paces it by the wall clock (`parallax stream walk` does).
    virtual bool realTime() const { return false; }
};

}  // namespace plx::stream
