#pragma once
// The HTTP/1.1 transport of the streaming client (Marvie & Bouatouch section 6: the client sends
// its requests to "the server"; here any static web server): whole files with GET, PTM level
// groups with one `Range: bytes=first-last` request each, over one persistent (keep-alive)
// connection, served FIFO by a worker thread. Every response is untrusted: status, Content-Range
// and Content-Length are checked before the body is read, and the body is bounded by the
// request's maxBytes. Serving a database: docs/stream-http.md.

#include <cstdint>
#include <memory>
#include <string>

#include <plx/core/status.h>
#include <plx/stream/fetch.h>

namespace plx::stream {

struct HttpOptions {
    // Opening the TCP connection (name resolution included), seconds.
    double connectTimeoutS = 3.0;
    // The longest wait for the next bytes of a response (request written, headers, each body
    // read), seconds: a server that stops sending fails the request after this long.
    double readTimeoutS = 5.0;
    // A body that arrives slower than this over a whole readTimeoutS fails the request like a
    // timeout (retried): the read timeout bounds each pause only, and a server that drips a byte
    // per pause held a 356-byte request for 12 minutes. 1 KiB/s is a seventh of the paper's
    // slowest link (56 kbit/s); 0 turns the check off.
    double minBodyBytesPerS = 1024.0;
    // Tries of one request when the connection fails, times out or the server answers 5xx;
    // wrong ranges, lengths and 4xx fail at once (retrying would get the same answer).
    int maxAttempts = 3;
    // Wait before the second try, doubled before each later one, seconds.
    double retryBackoffS = 0.1;
};

// A base URL split into its parts: http://HOST[:PORT]/PATH.
struct HttpUrl {
    std::string host;      // a name or dotted IPv4 address: [A-Za-z0-9.-]
    uint16_t port = 80;    // 1..65535
    std::string basePath;  // starts and ends with '/'; unreserved characters and '/' only
};

// Parses and validates a base URL. Only http; no user, query, fragment, IPv6 literal, ".." or
// percent sign. Errors are one line naming the URL and the problem.
Result<HttpUrl> parseHttpUrl(const std::string& url);

// A Fetcher over HTTP/1.1 to the database rooted at `url` (a request's path is appended to its
// basePath). Connects lazily, on the first request; a connection failure is the failed
// completion of that request. Errors: a bad URL or out-of-range options.
Result<std::unique_ptr<Fetcher>> openHttpFetcher(const std::string& url,
                                                 const HttpOptions& options = {});

// Parses a Content-Range header value "bytes FIRST-LAST/TOTAL" (TOTAL may be "*") and checks it
// names exactly `expected` (and TOTAL, when given, exceeds LAST). Errors say what differs.
Status checkContentRange(std::string_view value, const ByteRange& expected);

}  // namespace plx::stream
