// HTTP/1.1 transport with Boost.Beast (the only translation unit that includes it: Beast and Asio
// cost ~17 s and 700 MB to compile). Beast, not cpp-httplib, because its response parser stops
// after the headers (status, Content-Range and Content-Length are checked before any body byte
// is read), bounds the body (body_limit) without allocating from a declared length above it,
// and Beast's tcp_stream gives per-operation timeouts; it is also already a project dependency.
//
// One worker thread owns the io_context and the connection and runs each request's operations
// to completion (Marvie & Bouatouch section 6: one request at a time on one link, FIFO).

#include <plx/stream/http_fetch.h>

#include <cctype>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <limits>
#include <mutex>
#include <thread>
#include <utility>

#include <fmt/format.h>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/core/tcp_stream.hpp>
#include <boost/beast/http.hpp>

#include <plx/stream/database.h>

namespace plx::stream {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = asio::ip::tcp;
using Clock = std::chrono::steady_clock;

// Response headers larger than this are refused (nginx sends ~250 bytes).
constexpr uint32_t kMaxHeaderBytes = 16 * 1024;

bool isUnreserved(char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '.' || c == '_' ||
           c == '~';
}

// Untrusted text for an error message: printable ASCII only, at most 80 characters.
std::string printable(std::string_view text) {
    std::string out;
    for (char c : text.substr(0, 80)) out += (c >= 0x20 && c < 0x7f) ? c : '?';
    if (text.size() > 80) out += "...";
    return out;
}

// Digits only, 1..19 of them (no sign, no spaces, no overflow of uint64_t).
std::optional<uint64_t> parseDecimal(std::string_view s) {
    if (s.empty() || s.size() > 19) return std::nullopt;
    uint64_t v = 0;
    for (char c : s) {
        if (c < '0' || c > '9') return std::nullopt;
        v = v * 10 + uint64_t(c - '0');
    }
    return v;
}

std::chrono::steady_clock::duration seconds(double s) {
    return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

// The result of one try: ok, or a failure that another try may cure (connection, timeout, 5xx).
struct Outcome {
    Status status;
    bool retryable = false;
};

class HttpFetcher final : public Fetcher {
public:
    HttpFetcher(HttpUrl url, HttpOptions options)
        : mUrl(std::move(url)), mOptions(options), mStream(mIoc) {
        mWorker = std::thread([this] { serve(); });
    }

    ~HttpFetcher() override {
        {
            std::lock_guard lock(mMutex);
            mStop = true;
        }
        mWake.notify_all();
        // Aborts an operation in flight; runs on the worker (the io_context's only thread).
        asio::post(mIoc, [this] {
            beast::error_code ignored;
            mStream.socket().close(ignored);
        });
        mWorker.join();
    }

    void submit(FetchRequest request, double nowS) override {
        {
            std::lock_guard lock(mMutex);
            mQueue.push_back({std::move(request), nowS, Clock::now()});
            ++mOutstanding;
        }
        mWake.notify_all();
    }

    std::vector<FetchCompletion> poll(double /*nowS*/) override {
        std::lock_guard lock(mMutex);
        std::vector<FetchCompletion> out = std::move(mDone);
        mDone.clear();
        mOutstanding -= out.size();
        return out;
    }

    bool realTime() const override { return true; }
    size_t pending() const override {
        std::lock_guard lock(mMutex);
        return mOutstanding;
    }

private:
    struct Queued {
        FetchRequest request;
        double submittedAtS = 0.0;
        Clock::time_point submittedAt;
    };

    // The worker: takes requests in submission order and completes each before the next.
    void serve() {
        for (;;) {
            Queued q;
            {
                std::unique_lock lock(mMutex);
                mWake.wait(lock, [&] { return mStop || !mQueue.empty(); });
                if (mStop) return;
                q = std::move(mQueue.front());
                mQueue.pop_front();
            }
            FetchCompletion c = fetchWithRetries(q.request);
            c.id = q.request.id;
            c.submittedAtS = q.submittedAtS;
            c.finishedAtS = q.submittedAtS +
                            std::chrono::duration<double>(Clock::now() - q.submittedAt).count();
            std::lock_guard lock(mMutex);
            mDone.push_back(std::move(c));
        }
    }

    bool stopping() {
        std::lock_guard lock(mMutex);
        return mStop;
    }

    static Status checkRequest(const FetchRequest& r) {
        PLX_RETURN_IF_ERROR(checkUrl(r.path));
        if (r.maxBytes == 0) return errorStatus(ErrorCode::kInvalidArgument, "maxBytes is 0");
        // last - first, not size(): bytes 0-(2^64-1) would wrap size() to 0.
        if (r.range &&
            (r.range->last < r.range->first || r.range->last - r.range->first >= r.maxBytes)) {
            return errorStatus(ErrorCode::kInvalidArgument,
                               fmt::format("range not within 1..{} bytes", r.maxBytes));
        }
        return Status::ok();
    }

    // Bounded retries with exponential backoff; the failure names the request and the tries.
    FetchCompletion fetchWithRetries(const FetchRequest& r) {
        FetchCompletion c;
        if (Status s = checkRequest(r); !s) {
            c.status = errorStatus(
                s.code(), fmt::format("{}: {}", describeRequest(r.path, r.range), s.message()));
            return c;
        }
        std::chrono::duration<double> backoff(mOptions.retryBackoffS);
        for (int attempt = 1;; ++attempt) {
            Outcome o = fetchOnce(r, c.bytes);
            if (o.status.isOk()) return c;
            if (!o.retryable || attempt >= mOptions.maxAttempts || stopping()) {
                c.bytes.clear();
                c.status = errorStatus(
                    o.status.code(),
                    fmt::format("{}: {}{}", describeRequest(r.path, r.range), o.status.message(),
                                attempt > 1 ? fmt::format(" ({} tries)", attempt) : std::string()));
                return c;
            }
            std::unique_lock lock(mMutex);
            mWake.wait_for(lock, backoff, [&] { return mStop; });
            backoff *= 2;
        }
    }

    // Runs the operations started on the io_context to completion (timeouts end them).
    void runIo() {
        mIoc.restart();
        mIoc.run();
    }

    void closeConnection() {
        beast::error_code ignored;
        mStream.socket().shutdown(tcp::socket::shutdown_both, ignored);
        mStream.close();
        mBuffer.clear();
    }

    Outcome transportFailure(std::string_view when, const beast::error_code& ec) {
        closeConnection();
        std::string why = ec == beast::error::timeout
                              ? fmt::format("no answer within {} s", mOptions.readTimeoutS)
                              : ec.message();
        return {errorStatus(ErrorCode::kIoError, fmt::format("{}: {}", when, why)), true};
    }

    // Bytes of a body at the start of the current window of readTimeoutS.
    struct RateWindow {
        Clock::time_point start;
        size_t bytes = 0;
    };

    // Whether the body, now `bytes` long, came slower than minBodyBytesPerS over a window that
    // has ended; an ended window that was fast enough starts the next.
    bool tooSlow(RateWindow* window, size_t bytes) const {
        const auto now = Clock::now();
        const double elapsedS = std::chrono::duration<double>(now - window->start).count();
        if (elapsedS < mOptions.readTimeoutS) return false;
        if (double(bytes - window->bytes) < mOptions.minBodyBytesPerS * elapsedS) return true;
        *window = {now, bytes};
        return false;
    }

    Outcome reject(ErrorCode code, std::string why, bool retryable = false) {
        closeConnection();  // the rest of this response is unread or untrusted
        return {errorStatus(code, std::move(why)), retryable};
    }

    // Name resolution is the system resolver's (blocking; numeric hosts skip it).
    Outcome connect() {
        beast::error_code ec;
        tcp::resolver resolver(mIoc);
        auto endpoints = resolver.resolve(mUrl.host, std::to_string(mUrl.port), ec);
        if (ec) return transportFailure(fmt::format("resolving {}", mUrl.host), ec);
        mStream.expires_after(seconds(mOptions.connectTimeoutS));
        mStream.async_connect(endpoints,
                              [&](beast::error_code e, const tcp::endpoint&) { ec = e; });
        runIo();
        if (ec)
            return transportFailure(fmt::format("connecting to {}:{}", mUrl.host, mUrl.port), ec);
        mStream.socket().set_option(tcp::no_delay(true), ec);
        return {};
    }

    // Checks status, Content-Range, Content-Encoding and Content-Length before the body.
    Outcome checkHeaders(const FetchRequest& r,
                         const http::response_parser<http::vector_body<uint8_t>>& parser) {
        const auto& res = parser.get();
        const unsigned expected = r.range ? 206 : 200;
        if (res.result_int() != expected) {
            return reject(res.result_int() == 404 ? ErrorCode::kNotFound : ErrorCode::kIoError,
                          fmt::format("status {} (expected {})", res.result_int(), expected),
                          res.result_int() >= 500);
        }
        if (r.range) {
            auto it = res.find(http::field::content_range);
            if (it == res.end())
                return reject(ErrorCode::kCorruptData, "206 without Content-Range");
            Status s = checkContentRange(it->value(), *r.range);
            if (!s) return reject(s.code(), s.message());
        }
        auto enc = res.find(http::field::content_encoding);
        if (enc != res.end() && enc->value() != "identity") {
            return reject(ErrorCode::kCorruptData,
                          fmt::format("Content-Encoding '{}'", printable(enc->value())));
        }
        const uint64_t want = r.range ? r.range->size() : r.maxBytes;
        if (auto length = parser.content_length()) {
            if (r.range && *length != want) {
                return reject(ErrorCode::kCorruptData,
                              fmt::format("Content-Length {}, the range holds {}", *length, want));
            }
            if (*length > want) {
                return reject(
                    ErrorCode::kOutOfRange,
                    fmt::format("Content-Length {} above the {} bytes accepted", *length, want));
            }
        }
        return {};
    }

    // One request and its response on the persistent connection.
    Outcome fetchOnce(const FetchRequest& r, std::vector<uint8_t>& body) {
        body.clear();
        if (!mStream.socket().is_open()) {
            if (Outcome o = connect(); !o.status) return o;
        }
        http::request<http::empty_body> req{http::verb::get, mUrl.basePath + r.path, 11};
        req.set(http::field::host, fmt::format("{}:{}", mUrl.host, mUrl.port));
        req.set(http::field::user_agent, "parallax");
        req.keep_alive(true);
        if (r.range)
            req.set(http::field::range, fmt::format("bytes={}-{}", r.range->first, r.range->last));

        beast::error_code ec;
        auto done = [&](beast::error_code e, size_t) { ec = e; };
        mStream.expires_after(seconds(mOptions.readTimeoutS));
        http::async_write(mStream, req, done);
        runIo();
        if (ec) return transportFailure("sending the request", ec);

        http::response_parser<http::vector_body<uint8_t>> parser;
        parser.header_limit(kMaxHeaderBytes);
        // No limit while reading the headers, so that a 404 with a long page still reports its
        // status; checkHeaders bounds Content-Length before the body (and its allocation,
        // which Beast makes on the first body read) starts.
        parser.body_limit(std::numeric_limits<uint64_t>::max());
        mStream.expires_after(seconds(mOptions.readTimeoutS));
        http::async_read_header(mStream, mBuffer, parser, done);
        runIo();
        if (ec) return transportFailure("reading the headers", ec);
        if (Outcome o = checkHeaders(r, parser); !o.status) return o;
        const uint64_t limit = r.range ? r.range->size() : r.maxBytes;
        parser.body_limit(limit);  // bounds chunked and close-delimited bodies

        // The body, with the read timeout renewed per read: it bounds a stall, not the total
        // time (a throttled link legitimately takes long for a large group); the rate over each
        // window of readTimeoutS bounds a drip.
        RateWindow window{Clock::now(), parser.get().body().size()};
        while (!parser.is_done()) {
            mStream.expires_after(seconds(mOptions.readTimeoutS));
            http::async_read_some(mStream, mBuffer, parser, done);
            runIo();
            if (!ec && !parser.is_done() && tooSlow(&window, parser.get().body().size())) {
                closeConnection();
                return {errorStatus(ErrorCode::kIoError,
                                    fmt::format("body slower than {:g} bytes/s for {:g} s",
                                                mOptions.minBodyBytesPerS, mOptions.readTimeoutS)),
                        true};
            }
            if (ec == http::error::body_limit) {
                return reject(ErrorCode::kOutOfRange,
                              fmt::format("body longer than the {} bytes accepted", limit));
            }
            if (ec) {
                return transportFailure(
                    fmt::format("reading the body after {} bytes", parser.get().body().size()), ec);
            }
        }
        const bool keepAlive = parser.get().keep_alive();
        body = std::move(parser.release().body());
        if (r.range && body.size() != r.range->size()) {
            return reject(
                ErrorCode::kCorruptData,
                fmt::format("body of {} bytes, the range holds {}", body.size(), r.range->size()));
        }
        // Bytes already here past the end of the message: the server sent more than it
        // declared, so nothing more on this connection can be trusted.
        if (mBuffer.size() > 0) {
            return reject(
                ErrorCode::kCorruptData,
                fmt::format("{} bytes past the declared end of the body", mBuffer.size()));
        }
        if (!keepAlive) closeConnection();
        return {};
    }

    const HttpUrl mUrl;
    const HttpOptions mOptions;
    asio::io_context mIoc;  // run by the worker only
    beast::tcp_stream mStream;
    beast::flat_buffer mBuffer;

    mutable std::mutex mMutex;  // guards the members below
    std::condition_variable mWake;
    std::deque<Queued> mQueue;
    std::vector<FetchCompletion> mDone;
    size_t mOutstanding = 0;  // submitted and not yet returned by poll
    bool mStop = false;

    std::thread mWorker;  // last: starts after every other member exists
};

}  // namespace

Result<HttpUrl> parseHttpUrl(const std::string& url) {
    auto bad = [&](std::string_view why) {
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("URL '{}': {}", printable(url), why));
    };
    constexpr std::string_view kScheme = "http://";
    if (!std::string_view(url).starts_with(kScheme)) {
        return bad("only http://HOST:PORT/PATH is supported");
    }
    const std::string_view rest = std::string_view(url).substr(kScheme.size());
    const size_t slash = rest.find('/');
    const std::string_view authority = rest.substr(0, slash);
    const std::string_view path = slash == std::string_view::npos ? "/" : rest.substr(slash);
    if (authority.find('@') != std::string_view::npos)
        return bad("user names and passwords (user:pass@) are not supported");
    const size_t colon = authority.find(':');
    const std::string_view host = authority.substr(0, colon);
    if (host.empty()) return bad("no host");
    for (char c : host) {
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '-') {
            return bad("the host may hold only letters, digits, '.' and '-'");
        }
    }
    HttpUrl out;
    out.host = std::string(host);
    if (colon != std::string_view::npos) {
        auto port = parseDecimal(authority.substr(colon + 1));
        if (!port || *port == 0 || *port > 65535) return bad("the port must be 1..65535");
        out.port = static_cast<uint16_t>(*port);
    }
    for (char c : path) {
        if (!isUnreserved(c) && c != '/') {
            return bad("the path may hold only letters, digits, '-', '.', '_', '~' and '/'");
        }
    }
    for (size_t begin = 0; begin < path.size();) {
        size_t end = std::min(path.find('/', begin), path.size());
        std::string_view segment = path.substr(begin, end - begin);
        if (segment == "." || segment == "..") return bad("the path may not hold '.' or '..'");
        begin = end + 1;
    }
    out.basePath = std::string(path);
    if (out.basePath.back() != '/') out.basePath += '/';
    return out;
}

Status checkContentRange(std::string_view value, const ByteRange& expected) {
    auto bad = [&](std::string_view why) {
        return errorStatus(ErrorCode::kCorruptData,
                           fmt::format("Content-Range '{}' {}", printable(value), why));
    };
    constexpr std::string_view kUnit = "bytes ";
    if (!value.starts_with(kUnit)) return bad("is not in bytes");
    const std::string_view spec = value.substr(kUnit.size());
    const size_t dash = spec.find('-'), slash = spec.find('/');
    if (dash == std::string_view::npos || slash == std::string_view::npos || slash < dash) {
        return bad("is not FIRST-LAST/TOTAL");
    }
    auto first = parseDecimal(spec.substr(0, dash));
    auto last = parseDecimal(spec.substr(dash + 1, slash - dash - 1));
    if (!first || !last || *last < *first) return bad("has no valid FIRST-LAST");
    const std::string_view totalText = spec.substr(slash + 1);
    if (totalText != "*") {
        auto total = parseDecimal(totalText);
        if (!total || *total <= *last) return bad("has no valid TOTAL past LAST");
    }
    if (*first != expected.first || *last != expected.last) {
        return bad(
            fmt::format("differs from the requested bytes {}-{}", expected.first, expected.last));
    }
    return Status::ok();
}

Result<std::unique_ptr<Fetcher>> openHttpFetcher(const std::string& url,
                                                 const HttpOptions& options) {
    auto parsed = parseHttpUrl(url);
    if (!parsed) return parsed.status();
    auto within = [](double v, double lo, double hi) { return v >= lo && v <= hi; };
    if (!within(options.connectTimeoutS, 1e-3, 3600) || !within(options.readTimeoutS, 1e-3, 3600) ||
        options.maxAttempts < 1 || options.maxAttempts > 10 ||
        !within(options.retryBackoffS, 0, 60) || !within(options.minBodyBytesPerS, 0, 1e9)) {
        return errorStatus(ErrorCode::kInvalidArgument,
                           "HTTP options: timeouts 0.001..3600 s, 1..10 attempts, backoff 0..60 s, "
                           "minimum body rate 0..1e9 bytes/s");
    }
    return std::unique_ptr<Fetcher>(new HttpFetcher(std::move(*parsed), options));
}

}  // namespace plx::stream
