#pragma once
// The error of every PTM parser and decoder on bytes that break the format (docs/ptm-format.md).

#include <string>

#include <plx/core/status.h>

namespace plx::ptm {

inline Status corrupt(std::string message) {
    return errorStatus(ErrorCode::kCorruptData, "PTM: " + std::move(message));
}

}  // namespace plx::ptm
