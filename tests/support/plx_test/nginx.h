#pragma once
// nginx (Debian nginx-light) started by a test: run in the foreground as the current user, with
// its prefix, configuration, pid, logs and temp folders inside one temporary folder, listening on
// loopback only, and stopped (SIGTERM, then waited for) when the object goes. Shared by the HTTP
// Range tests (libs/stream) and the reverse-proxy test of remote sessions (tests/integration).

#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <thread>

extern char** environ;

namespace plx::testing {

// A TCP port on 127.0.0.1 that was free a moment ago (bound to port 0 and released).
inline uint16_t freeLoopbackPort() {
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
    socklen_t len = sizeof a;
    getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    close(fd);
    return ntohs(a.sin_port);
}

// Whether something accepts TCP connections on 127.0.0.1:port now.
inline bool acceptsConnections(uint16_t port) {
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    bool ok = ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    close(fd);
    return ok;
}

class NginxProcess {
public:
    static constexpr const char* kNginx = "/usr/sbin/nginx";
    static bool available() { return std::filesystem::exists(kNginx); }

    // The head of a test configuration, up to and including "http {": foreground, one worker,
    // pid, logs and every temp path inside `tmp`. The caller adds its http block's body and
    // the closing brace.
    static std::string prelude(const std::filesystem::path& tmp) {
        const std::string t = tmp.string();
        std::ostringstream c;
        c << "daemon off;\nworker_processes 1;\npid " << t << "/nginx.pid;\nerror_log " << t
          << "/error.log;\nevents { worker_connections 64; }\nhttp {\n"
          << "    access_log " << t << "/access.log;\n"
          << "    client_body_temp_path " << t << "/body;\n    proxy_temp_path " << t
          << "/proxy;\n    fastcgi_temp_path " << t << "/fastcgi;\n    uwsgi_temp_path " << t
          << "/uwsgi;\n    scgi_temp_path " << t << "/scgi;\n";
        return c.str();
    }

    // Writes `config` to tmp/nginx.conf and starts nginx on it; `port` is the one it listens on
    // (ready() waits for it).
    NginxProcess(const std::filesystem::path& tmp, const std::string& config, uint16_t port)
        : mTmp(tmp), mPort(port) {
        std::ofstream(tmp / "nginx.conf") << config;
        const std::string prefix = tmp.string() + "/", confPath = (tmp / "nginx.conf").string(),
                          errorLog = (tmp / "error.log").string();
        const char* argv[] = {kNginx,           "-p", prefix.c_str(),   "-c",
                              confPath.c_str(), "-e", errorLog.c_str(), nullptr};
        if (posix_spawn(&mPid, kNginx, nullptr, nullptr, const_cast<char**>(argv), environ) != 0)
            mPid = -1;
    }
    NginxProcess(const NginxProcess&) = delete;
    NginxProcess& operator=(const NginxProcess&) = delete;
    ~NginxProcess() {
        if (mPid <= 0) return;
        kill(mPid, SIGTERM);
        int status = 0;
        waitpid(mPid, &status, 0);
    }

    // Waits (at most 10 s) until nginx accepts connections; false when it exited or never did.
    bool ready() {
        for (int i = 0; i < 500 && mPid > 0; ++i) {
            int status = 0;
            if (waitpid(mPid, &status, WNOHANG) == mPid) {
                mPid = -1;
                return false;
            }
            if (acceptsConnections(mPort)) return true;
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
        return false;
    }

    uint16_t port() const { return mPort; }
    std::string url(const char* location) const {
        return "http://127.0.0.1:" + std::to_string(mPort) + "/" + location;
    }
    std::string errorLog() const { return fileText(mTmp / "error.log"); }

    static std::string fileText(const std::filesystem::path& path) {
        std::ifstream in(path, std::ios::binary);
        return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    }

private:
    std::filesystem::path mTmp;
    uint16_t mPort = 0;
    pid_t mPid = -1;
};

}  // namespace plx::testing
