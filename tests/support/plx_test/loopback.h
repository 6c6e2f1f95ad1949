#pragma once
// Plain TCP peers on loopback for the servers' hardening tests: a connection that sends nothing,
// and whether its server closed it. Shared by the transport tests (libs/remote) and the CLI tests
// of `parallax serve` (apps/parallax).

#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>

namespace plx::testing {

// A plain TCP connection to 127.0.0.1:port that sends nothing; -1 if it failed. `from` is the
// loopback address it comes from (Linux's lo holds all of 127.0.0.0/8): 1 for 127.0.0.1, 2 for
// 127.0.0.2 (a second client address without leaving the machine).
inline int silentConnection(int port, uint8_t from = 1) {
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in source{};
    source.sin_family = AF_INET;
    source.sin_addr.s_addr = htonl(INADDR_LOOPBACK - 1 + from);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(uint16_t(port));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (fd >= 0 && bind(fd, reinterpret_cast<sockaddr*>(&source), sizeof source) == 0 &&
        connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0)
        return fd;
    if (fd >= 0) close(fd);
    return -1;
}

// Whether the server closed a silent connection within `limit` (it sends such a peer nothing).
inline bool closedByPeer(int fd, std::chrono::milliseconds limit) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, int(limit.count())) != 1) return false;
    char c;
    return recv(fd, &c, 1, MSG_DONTWAIT) <= 0;
}

}  // namespace plx::testing
