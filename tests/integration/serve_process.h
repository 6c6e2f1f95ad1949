#pragma once
// A `parallax serve` started by a test in the background, on a free loopback port (--port 0),
// stopping by itself after 30 s at most: the integration tests of remote sessions (the CLI's
// own, the reverse-proxy test).

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace plx::testing {

// A `parallax serve` in the background: its pid and the port from its first JSON line.
class ServeProcess {
public:
    // shellPrefix runs in the shell before the server starts ("ulimit -n 64; ").
    explicit ServeProcess(const std::string& args, const std::string& shellPrefix = "") {
        // The shell prints its pid, then becomes `timeout`, the server's parent (exec keeps the
        // pid).
        std::string cmd = "sh -c 'echo $$; " + shellPrefix + "exec timeout 60 " +
                          std::string(PARALLAX_EXE) + " serve " + args +
                          " --port 0 --json --seconds 30' 2>/dev/null";
        mPipe = popen(cmd.c_str(), "r");
        if (!mPipe) return;
        char line[4096];
        if (fgets(line, sizeof line, mPipe)) mPid = std::atoi(line);
        if (fgets(line, sizeof line, mPipe))
            listening = nlohmann::json::parse(line, nullptr, false);
    }
    ServeProcess(const ServeProcess&) = delete;
    ServeProcess& operator=(const ServeProcess&) = delete;
    ~ServeProcess() { stop(); }
    int port() const { return listening.is_object() ? listening.value("port", 0) : 0; }
    std::string url() const { return "ws://127.0.0.1:" + std::to_string(port()); }
    // SIGTERM; returns the "stopped" JSON line (the last) and the exit code, and keeps the
    // session lines before it in `sessionLines`.
    std::pair<nlohmann::json, int> stop() {
        if (!mPipe) return {{}, -1};
        if (mPid > 0) kill(mPid, SIGTERM);
        std::vector<nlohmann::json> lines;
        char buf[4096];
        while (fgets(buf, sizeof buf, mPipe))
            lines.push_back(nlohmann::json::parse(buf, nullptr, false));
        int status = pclose(mPipe);
        mPipe = nullptr;
        nlohmann::json stopped = lines.empty() ? nlohmann::json() : lines.back();
        if (!lines.empty()) lines.pop_back();
        sessionLines = std::move(lines);
        return {stopped, WIFEXITED(status) ? WEXITSTATUS(status) : -1};
    }
    // CPU seconds the server has used so far (user and system); < 0 if it cannot be read.
    double cpuSeconds() const {
        const std::string task =
            "/proc/" + std::to_string(mPid) + "/task/" + std::to_string(mPid) + "/children";
        int server = 0;
        if (!(std::ifstream(task) >> server)) return -1.0;
        std::ifstream statFile("/proc/" + std::to_string(server) + "/stat");
        std::string stat((std::istreambuf_iterator<char>(statFile)), {});
        const size_t afterName = stat.rfind(')');
        if (afterName == std::string::npos) return -1.0;
        // Fields after the name: state (3) ... utime (14) and stime (15), in clock ticks.
        std::istringstream fields(stat.substr(afterName + 2));
        std::string skip;
        for (int i = 3; i < 14; ++i) fields >> skip;
        double utime = 0.0, stime = 0.0;
        if (!(fields >> utime >> stime)) return -1.0;
        return (utime + stime) / double(sysconf(_SC_CLK_TCK));
    }
    nlohmann::json listening;
    std::vector<nlohmann::json> sessionLines;  // after stop()

private:
    FILE* mPipe = nullptr;
    int mPid = 0;
};

}  // namespace plx::testing
