#include "chungs/store/zstd_limits.hpp"

#include <zstd.h>

#include "chungs/common/error.hpp"

namespace chungs {

void check_zstd_expansion(const std::filesystem::path& file, const std::string& what, uint64_t raw_bytes,
                          uint64_t payload_bytes) {
  // Divided, not multiplied: payload_bytes comes from the file too and may be near 2^64.
  const uint64_t least = raw_bytes / kMaxZstdExpansion + (raw_bytes % kMaxZstdExpansion != 0);
  if (least > payload_bytes)
    fail(file.string(), ": ", what, " in the header: ", raw_bytes, " bytes, more than a zstd payload of ",
         payload_bytes, " bytes holds (zstd expands at most ", kMaxZstdExpansion, " times)");
}

void check_zstd_content_size(const std::filesystem::path& file, const void* payload, size_t payload_bytes,
                             uint64_t raw_bytes) {
  const unsigned long long declared = ZSTD_getFrameContentSize(payload, payload_bytes);
  if (declared == ZSTD_CONTENTSIZE_ERROR) fail(file.string(), ": payload is not a zstd frame");
  if (declared != ZSTD_CONTENTSIZE_UNKNOWN && declared != raw_bytes)
    fail(file.string(), ": zstd frame declares ", declared, " bytes but the header announces ", raw_bytes);
}

}  // namespace chungs
