#include <plx/ptm/format.h>

#include "kernels.h"

namespace plx::ptm {

uint32_t crc32Portable(std::span<const uint8_t> bytes, uint32_t crc) {
    return ~detail::isa_scalar::crc32Update(bytes.data(), bytes.size(), ~crc);
}

// The ISA is picked per call: a call covers a whole group or header.
uint32_t crc32(std::span<const uint8_t> bytes, uint32_t crc) {
    using namespace detail;
    return ~PLX_ISA_PICK(crc32Update)(bytes.data(), bytes.size(), ~crc);
}

}  // namespace plx::ptm
