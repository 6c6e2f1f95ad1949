#pragma once
// Wall-clock timing for experiment drivers and the CLI (never for pass/fail tests).

#include <algorithm>
#include <chrono>
#include <vector>

namespace plx {

class Stopwatch {
public:
    Stopwatch() : mStart(Clock::now()) {}
    void restart() { mStart = Clock::now(); }
    double elapsedMs() const {
        return std::chrono::duration<double, std::milli>(Clock::now() - mStart).count();
    }

private:
    using Clock = std::chrono::steady_clock;
    Clock::time_point mStart;
};

// Median of the samples (mean of the middle two for an even count); 0 for none.
inline double median(std::vector<double> samples) {
    if (samples.empty()) return 0.0;
    std::sort(samples.begin(), samples.end());
    size_t n = samples.size();
    return n % 2 ? samples[n / 2] : 0.5 * (samples[n / 2 - 1] + samples[n / 2]);
}

}  // namespace plx
