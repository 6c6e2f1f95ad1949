#pragma once
// How much memory this process may still take, and how much it has taken: for commands that
// refuse work too large for the machine up front, with a message, rather than being ended by
// the kernel's out-of-memory killer without one.

#include <cstdint>
#include <optional>
#include <string>

namespace plx {

// Bytes this process can still allocate and touch: the least of
//  - the system's MemAvailable plus free swap (/proc/meminfo),
//  - what its memory cgroup still allows (cgroupMemoryRemaining),
//  - RLIMIT_AS less the address space it holds (VmSize), and RLIMIT_DATA less its data
//    mappings (VmData), where those limits are set (ulimit -v, ulimit -d).
// nullopt where the system does not say (no /proc/meminfo).
std::optional<uint64_t> availableMemoryBytes();

// RLIMIT_AS (ulimit -v) less the address space this process maps now; nullopt without a limit.
std::optional<uint64_t> addressSpaceRemaining();

// What the memory cgroup of the process (as `cgroupFile` lists it, under the hierarchy mounted at
// `root`) still allows: its limit less its usage, the inactive file cache (which the kernel
// reclaims before it ends anything) not counted as used. cgroup v2 (memory.max, memory.current,
// memory.stat's inactive_file) or v1 (memory.limit_in_bytes, memory.usage_in_bytes,
// total_inactive_file), the first listed with both files readable; nullopt without a limit
// ("max") or such a hierarchy.
std::optional<uint64_t> cgroupMemoryRemaining(const std::string& cgroupFile = "/proc/self/cgroup",
                                              const std::string& root = "/sys/fs/cgroup");

// The address space this process maps now (VmSize) and the resident memory it holds
// (/proc/self/statm), and the most it has held (getrusage's ru_maxrss). 0 where the system does
// not say.
uint64_t mappedBytes();
uint64_t residentBytes();
uint64_t peakResidentBytes();

}  // namespace plx
