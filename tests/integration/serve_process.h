#pragma once
// A `parallax serve` started by a test in the background, on a free loopback port (--port 0),
// its JSON lines on a pipe the test reads, stops reading or closes; it stops by itself after 30 s
// (and is killed after 60): the integration tests of remote sessions (the CLI's own, the
// reverse-proxy test).

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace plx::testing {

// What the server starts with beyond its arguments.
struct ServeSetup {
    rlim_t openFilesSoft = 0;  // RLIMIT_NOFILE's soft limit (0: inherited), as `ulimit -Sn`
    rlim_t openFilesHard = 0;  // and its hard limit (0: inherited), as `ulimit -Hn`
    int pipeBytes = 0;         // the size of its stdout's pipe (0: the system's)
};

// A `parallax serve ARGS --port 0 --json --seconds 30` in the background: its pid, and the port
// from its first JSON line.
class ServeProcess {
public:
    // args: the scene and options, separated by spaces (no quoting).
    explicit ServeProcess(const std::string& args, const ServeSetup& setup = {}) {
        std::vector<std::string> argv = {PARALLAX_EXE, "serve"};
        std::istringstream words(args + " --port 0 --json --seconds 30");
        for (std::string w; words >> w;) argv.push_back(w);
        std::vector<char*> raw;  // built before fork: the child only calls what exec allows
        for (std::string& a : argv) raw.push_back(a.data());
        raw.push_back(nullptr);
        int out[2];
        if (pipe2(out, O_CLOEXEC) != 0) return;
        if (setup.pipeBytes > 0) fcntl(out[0], F_SETPIPE_SZ, setup.pipeBytes);
        mPid = fork();
        if (mPid == 0) {
            dup2(out[1], STDOUT_FILENO);  // dup2 clears close-on-exec on the copy
            if (int null = open("/dev/null", O_WRONLY); null >= 0) dup2(null, STDERR_FILENO);
            rlimit files{};
            getrlimit(RLIMIT_NOFILE, &files);
            if (setup.openFilesHard > 0) files.rlim_max = setup.openFilesHard;
            if (setup.openFilesSoft > 0) files.rlim_cur = setup.openFilesSoft;
            setrlimit(RLIMIT_NOFILE, &files);
            alarm(60);  // kept across exec: a server that hangs dies of SIGALRM
            execv(PARALLAX_EXE, raw.data());
            _exit(127);
        }
        close(out[1]);
        mFd = out[0];
        if (mPid > 0)
            listening = nlohmann::json::parse(readLine(), nullptr, false);
        else
            closeReader();
    }
    ServeProcess(const ServeProcess&) = delete;
    ServeProcess& operator=(const ServeProcess&) = delete;
    ~ServeProcess() {
        if (mPid > 0) stop();
        closeReader();
    }
    int port() const { return listening.is_object() ? listening.value("port", 0) : 0; }
    std::string url() const { return "ws://127.0.0.1:" + std::to_string(port()); }

    // One line of its stdout (without its newline), at most 64 KiB; empty at the end.
    std::string readLine() {
        std::string line;
        for (char c; line.size() < (64u << 10) && read(mFd, &c, 1) == 1 && c != '\n';) line += c;
        return line;
    }
    // The reader goes away: what the server writes next finds no one (`serve --json | head -1`).
    void closeReader() {
        if (mFd >= 0) close(mFd);
        mFd = -1;
    }

    // SIGTERM; returns the "stopped" JSON line (the last; null if the reader was closed) and the
    // exit code (-1 for a signal), and keeps the session lines before it in `sessionLines`.
    std::pair<nlohmann::json, int> stop() {
        if (mPid <= 0) return {{}, -1};
        kill(mPid, SIGTERM);
        std::vector<nlohmann::json> lines;
        for (std::string l; mFd >= 0 && !(l = readLine()).empty();)
            lines.push_back(nlohmann::json::parse(l, nullptr, false));
        int status = 0;
        waitpid(mPid, &status, 0);
        mPid = 0;
        nlohmann::json stopped = lines.empty() ? nlohmann::json() : lines.back();
        if (!lines.empty()) lines.pop_back();
        sessionLines = std::move(lines);
        return {stopped, WIFEXITED(status) ? WEXITSTATUS(status) : -1};
    }

    // CPU seconds the server has used so far (user and system); < 0 if it cannot be read.
    double cpuSeconds() const {
        std::ifstream statFile("/proc/" + std::to_string(mPid) + "/stat");
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
    pid_t mPid = 0;
    int mFd = -1;
};

}  // namespace plx::testing
