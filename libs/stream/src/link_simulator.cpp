// The simulated link: requests are served from files below the database folder, then delayed as
// one FIFO link would: a transfer starts when the previous one ends (or at its submission), waits
// the latency, then takes bytes * 8 / bandwidth seconds.
#include <plx/stream/link_simulator.h>

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include <plx/core/file.h>
#include <plx/stream/database.h>

namespace plx::stream {

LinkSimulator::LinkSimulator(std::string root, LinkOptions options)
    : mRoot(std::move(root)), mOptions(options) {
    PLX_CHECK(std::isfinite(options.bandwidthBitsPerS) && options.bandwidthBitsPerS >= 0.0);
    PLX_CHECK(std::isfinite(options.latencyS) && options.latencyS >= 0.0);
}

// Reads the request's bytes: the URL checked first (no absolute path, no "..": reads stay below
// the folder), the file through the checked opener, the range clipped to the file as HTTP does.
FetchCompletion LinkSimulator::serve(const FetchRequest& request, Fault fault) const {
    FetchCompletion out;
    out.id = request.id;
    auto fail = [&](ErrorCode code, const std::string& why) {
        out.status = errorStatus(
            code, fmt::format("{}: {}", describeRequest(request.path, request.range), why));
        out.bytes.clear();
        return out;
    };
    if (fault == Fault::kFail) return fail(ErrorCode::kIoError, "request failed (injected)");
    if (Status s = checkUrl(request.path); !s) return fail(ErrorCode::kInvalidArgument, s.message());
    // A whole-file body is limited by the file's size; a range's body is checked below.
    uint64_t limit = request.maxBytes && !request.range ? request.maxBytes : kDefaultMaxFileBytes;
    auto text = readFileChecked(mRoot + "/" + request.path, limit);
    if (!text) return fail(text.status().code(), text.status().message());
    const std::string& file = text.value();
    size_t first = 0, last = file.size();
    if (request.range) {
        if (request.range->first > request.range->last || request.range->first >= file.size())
            return fail(ErrorCode::kOutOfRange, "range not satisfiable");
        first = size_t(request.range->first);
        // The end clipped before the + 1: a last of 2^64 - 1 would wrap to an empty body.
        last = size_t(std::min<uint64_t>(request.range->last, file.size() - 1)) + 1;
    }
    if (request.maxBytes && last - first > request.maxBytes)
        return fail(ErrorCode::kOutOfRange, fmt::format("body of {} bytes over the limit of {}",
                                                        last - first, request.maxBytes));
    out.bytes.assign(file.begin() + long(first), file.begin() + long(last));
    if (fault == Fault::kTruncate && !out.bytes.empty()) out.bytes.resize(out.bytes.size() / 2);
    if (fault == Fault::kCorrupt && !out.bytes.empty()) out.bytes[out.bytes.size() / 2] ^= 0x5A;
    return out;
}

void LinkSimulator::submit(FetchRequest request, double nowS) {
    auto it = mFaults.find(mSubmitted++);
    Fault fault = it == mFaults.end() ? Fault::kNone : it->second;
    Queued q;
    q.completion = serve(request, fault);
    q.submittedAtS = nowS;
    // The transfer occupies the link after the previous one; a failed request costs the latency.
    double start = std::max(nowS, mLinkFreeAtS) + mOptions.latencyS;
    double bits = 8.0 * double(q.completion.bytes.size());
    double transfer = mOptions.bandwidthBitsPerS > 0.0 ? bits / mOptions.bandwidthBitsPerS : 0.0;
    q.finishedAtS = start + transfer;
    mLinkFreeAtS = q.finishedAtS;
    q.completion.submittedAtS = nowS;
    q.completion.finishedAtS = q.finishedAtS;
    q.request = std::move(request);
    mQueue.push_back(std::move(q));
}

std::vector<FetchCompletion> LinkSimulator::poll(double nowS) {
    std::vector<FetchCompletion> done;
    while (!mQueue.empty() && mQueue.front().finishedAtS <= nowS) {
        done.push_back(std::move(mQueue.front().completion));
        mQueue.pop_front();
    }
    return done;
}

}  // namespace plx::stream
