#pragma once
// How much memory this process may still take, and how much it has taken: for commands that
// refuse work too large for the machine up front, with a message, rather than being ended by
// the kernel's out-of-memory killer without one.

#include <cstdint>
#include <optional>

namespace plx {

// Bytes this process can still allocate and touch: the least of
//  - the system's MemAvailable plus free swap (/proc/meminfo),
//  - its cgroup's memory.max less memory.current (cgroup v2, where a limit is set),
//  - RLIMIT_AS less the address space it holds (VmSize), and RLIMIT_DATA less its data
//    mappings (VmData), where those limits are set (ulimit -v, ulimit -d).
// nullopt where the system does not say (no /proc/meminfo).
std::optional<uint64_t> availableMemoryBytes();

// The resident memory this process holds now (/proc/self/statm), and the most it has held
// (getrusage's ru_maxrss). 0 where the system does not say.
uint64_t residentBytes();
uint64_t peakResidentBytes();

}  // namespace plx
