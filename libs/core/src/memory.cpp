#include <plx/core/memory.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <string>

#include <sys/resource.h>
#include <unistd.h>

namespace plx {
namespace {

// The number after `key` on its line of a file of "key value" lines: /proc/meminfo's
// "MemAvailable:   N kB", a cgroup's memory.stat "inactive_file N".
std::optional<uint64_t> keyedNumber(const std::string& path, const std::string& key) {
    std::ifstream in(path);
    std::string line;
    while (std::getline(in, line))
        if (line.compare(0, key.size(), key) == 0) {
            std::istringstream value(line.substr(key.size()));
            uint64_t n = 0;
            if (value >> n) return n;
            return std::nullopt;
        }
    return std::nullopt;
}

// A cgroup interface file holding one number; nullopt for "max" (no limit) or no such file.
std::optional<uint64_t> fileNumber(const std::string& path) {
    std::ifstream in(path);
    uint64_t v = 0;
    if (in >> v) return v;
    return std::nullopt;
}

// What a resource limit still allows beyond `used` bytes; nullopt without one.
std::optional<uint64_t> rlimitRemaining(int resource, uint64_t used) {
    rlimit limit{};
    if (getrlimit(resource, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return std::nullopt;
    return limit.rlim_cur > used ? uint64_t(limit.rlim_cur) - used : 0;
}

// Field `index` of /proc/self/statm (0: the mapped size, 1: resident) in bytes; 0 if unread.
uint64_t statmBytes(int index) {
    std::ifstream in("/proc/self/statm");
    uint64_t pages = 0;
    for (int i = 0; i <= index; ++i)
        if (!(in >> pages)) return 0;
    return pages * uint64_t(sysconf(_SC_PAGESIZE));
}

}  // namespace

std::optional<uint64_t> cgroupMemoryRemaining(const std::string& cgroupFile,
                                              const std::string& root) {
    std::ifstream self(cgroupFile);
    std::string line;
    while (std::getline(self, line)) {
        // "hierarchy:controllers:path"; v2 is hierarchy 0 with no controllers listed.
        const size_t first = line.find(':'), second = line.find(':', first + 1);
        if (first == std::string::npos || second == std::string::npos) continue;
        const std::string controllers = line.substr(first + 1, second - first - 1);
        const std::string path = line.substr(second + 1);
        const bool v2 = line.compare(0, first, "0") == 0 && controllers.empty();
        const bool v1 = (',' + controllers + ',').find(",memory,") != std::string::npos;
        if (!v1 && !v2) continue;
        const std::string dir = root + (v2 ? "" : "/memory") + path;
        const auto limit = fileNumber(dir + (v2 ? "/memory.max" : "/memory.limit_in_bytes"));
        const auto usage = fileNumber(dir + (v2 ? "/memory.current" : "/memory.usage_in_bytes"));
        if (!limit || !usage) continue;
        const uint64_t inactive =
            keyedNumber(dir + "/memory.stat", v2 ? "inactive_file " : "total_inactive_file ")
                .value_or(0);
        const uint64_t used = *usage - std::min(inactive, *usage);
        return *limit > used ? *limit - used : 0;
    }
    return std::nullopt;
}

std::optional<uint64_t> availableMemoryBytes() {
    const auto memAvailable = keyedNumber("/proc/meminfo", "MemAvailable:");
    if (!memAvailable) return std::nullopt;
    uint64_t bytes = (*memAvailable + keyedNumber("/proc/meminfo", "SwapFree:").value_or(0)) * 1024;
    for (const std::optional<uint64_t>& bound :
         {cgroupMemoryRemaining(), addressSpaceRemaining(),
          rlimitRemaining(RLIMIT_DATA,
                          keyedNumber("/proc/self/status", "VmData:").value_or(0) * 1024)})
        if (bound) bytes = std::min(bytes, *bound);
    return bytes;
}

std::optional<uint64_t> addressSpaceRemaining() {
    return rlimitRemaining(RLIMIT_AS, mappedBytes());
}

uint64_t mappedBytes() {
    return statmBytes(0);
}

uint64_t residentBytes() {
    return statmBytes(1);
}

uint64_t peakResidentBytes() {
    rusage usage{};
    if (getrusage(RUSAGE_SELF, &usage) != 0) return 0;
    return uint64_t(usage.ru_maxrss) * 1024;  // Linux reports kilobytes
}

}  // namespace plx
