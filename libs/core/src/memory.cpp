#include <plx/core/memory.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <string>

#include <sys/resource.h>
#include <unistd.h>

namespace plx {
namespace {

// The value in kB of `key` ("MemAvailable:") in a /proc file of "Key:   N kB" lines.
std::optional<uint64_t> procKilobytes(const char* path, const std::string& key) {
    std::ifstream in(path);
    std::string line;
    while (std::getline(in, line))
        if (line.compare(0, key.size(), key) == 0) {
            std::istringstream value(line.substr(key.size()));
            uint64_t kb = 0;
            if (value >> kb) return kb;
            return std::nullopt;
        }
    return std::nullopt;
}

// A cgroup v2 interface file holding one number (or "max": no limit).
std::optional<uint64_t> cgroupNumber(const std::string& file) {
    std::ifstream in(file);
    uint64_t v = 0;
    if (in >> v) return v;
    return std::nullopt;
}

// What the process's cgroup (v2) still allows: memory.max less memory.current; nullopt without a
// limit.
std::optional<uint64_t> cgroupRemaining() {
    std::ifstream self("/proc/self/cgroup");
    std::string line;
    while (std::getline(self, line)) {
        if (line.rfind("0::", 0) != 0) continue;
        const std::string dir = "/sys/fs/cgroup" + line.substr(3);
        const auto limit = cgroupNumber(dir + "/memory.max");
        const auto used = cgroupNumber(dir + "/memory.current");
        if (!limit || !used) return std::nullopt;
        return *limit > *used ? *limit - *used : 0;
    }
    return std::nullopt;
}

// What a resource limit still allows beyond `usedKey` of /proc/self/status; nullopt without one.
std::optional<uint64_t> rlimitRemaining(int resource, const char* usedKey) {
    rlimit limit{};
    if (getrlimit(resource, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return std::nullopt;
    const uint64_t used = procKilobytes("/proc/self/status", usedKey).value_or(0) * 1024;
    return limit.rlim_cur > used ? uint64_t(limit.rlim_cur) - used : 0;
}

}  // namespace

std::optional<uint64_t> availableMemoryBytes() {
    const auto memAvailable = procKilobytes("/proc/meminfo", "MemAvailable:");
    if (!memAvailable) return std::nullopt;
    uint64_t bytes =
        (*memAvailable + procKilobytes("/proc/meminfo", "SwapFree:").value_or(0)) * 1024;
    for (const std::optional<uint64_t>& bound :
         {cgroupRemaining(), rlimitRemaining(RLIMIT_AS, "VmSize:"),
          rlimitRemaining(RLIMIT_DATA, "VmData:")})
        if (bound) bytes = std::min(bytes, *bound);
    return bytes;
}

uint64_t residentBytes() {
    std::ifstream in("/proc/self/statm");
    uint64_t sizePages = 0, residentPages = 0;
    if (!(in >> sizePages >> residentPages)) return 0;
    return residentPages * uint64_t(sysconf(_SC_PAGESIZE));
}

uint64_t peakResidentBytes() {
    rusage usage{};
    if (getrusage(RUSAGE_SELF, &usage) != 0) return 0;
    return uint64_t(usage.ru_maxrss) * 1024;  // Linux reports kilobytes
}

}  // namespace plx
