#pragma once
// A deterministic Fetcher over a local database folder: one simulated FIFO link with a fixed
// latency per request and a bandwidth, on the caller's (simulated) clock. Serves the section-7
// experiments (Marvie & Bouatouch, "our system allows to simulate a remote walkthrough ... at
// different bandwidths") and the client's tests, with optional fault injection.

#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <string>

#include <plx/stream/fetch.h>

namespace plx::stream {

// Link parameters shared by every transport the walk can open.
struct LinkOptions {
    double bandwidthBitsPerS = 0.0;  // 0: unlimited
    double latencyS = 0.0;           // per request, before its first byte
};

// What to do to one request (by submission order, from 0), for tests of hostile completions.
enum class Fault { kNone, kTruncate, kCorrupt, kFail };

class LinkSimulator final : public Fetcher {
public:
    // Precondition: bandwidth and latency finite and >= 0. `root` is the database folder.
    LinkSimulator(std::string root, LinkOptions options);
    // The n-th submitted request (from 0) completes with this fault.
    void injectFault(uint64_t submissionIndex, Fault fault) { mFaults[submissionIndex] = fault; }

    void submit(FetchRequest request, double nowS) override;
    std::vector<FetchCompletion> poll(double nowS) override;
    size_t pending() const override { return mQueue.size(); }

private:
    struct Queued {
        FetchRequest request;
        double submittedAtS = 0.0;
        double finishedAtS = 0.0;
        FetchCompletion completion;
    };
    FetchCompletion serve(const FetchRequest& request, Fault fault) const;

    std::string mRoot;
    LinkOptions mOptions;
    std::deque<Queued> mQueue;
    std::map<uint64_t, Fault> mFaults;
    uint64_t mSubmitted = 0;
    double mLinkFreeAtS = 0.0;  // when the link finishes the last queued transfer
};

// A transport for a location: a database folder gives a LinkSimulator with these options; an
// http:// URL needs the HTTP transport. Errors: a folder without root.json, an unknown scheme,
// a bandwidth or latency that is negative or not finite.
Result<std::unique_ptr<Fetcher>> openFetcher(const std::string& location,
                                             const LinkOptions& options);

}  // namespace plx::stream
