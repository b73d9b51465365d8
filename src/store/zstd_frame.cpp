#include "strata/store/zstd_frame.hpp"

#include <zstd.h>
#include <zstd_errors.h>

#include <memory>

#include "strata/core/error.hpp"

namespace strata::store {

std::vector<std::byte> zstd_compress(std::span<const std::byte> in, int level) {
  std::vector<std::byte> out(ZSTD_compressBound(in.size()));
  // One context per thread: ZSTD_compress would create and free one per call (per brick).
  thread_local std::unique_ptr<ZSTD_CCtx, decltype(&ZSTD_freeCCtx)> cctx(ZSTD_createCCtx(), &ZSTD_freeCCtx);
  const std::size_t n = ZSTD_compressCCtx(cctx.get(), out.data(), out.size(), in.data(), in.size(), level);
  if (ZSTD_isError(n))
    throw Error("zstd could not compress " + std::to_string(in.size()) + " bytes at level " + std::to_string(level) +
                " (zstd error code " + std::to_string(int(ZSTD_getErrorCode(n))) + ")");
  out.resize(n);
  return out;
}

void zstd_decompress(std::span<const std::byte> in, std::uint64_t limit, std::vector<std::byte>& out,
                     const std::string& file, const std::string& field) {
  const unsigned long long size = ZSTD_getFrameContentSize(in.data(), in.size());
  if (size == ZSTD_CONTENTSIZE_ERROR || size == ZSTD_CONTENTSIZE_UNKNOWN)
    throw FormatError(file, field, "not a zstd frame with a known content size");
  if (size > limit)
    throw FormatError(file, field, "decompressed size " + std::to_string(size) + " exceeds " + std::to_string(limit));
  out.resize(static_cast<std::size_t>(size));
  thread_local std::unique_ptr<ZSTD_DCtx, decltype(&ZSTD_freeDCtx)> dctx(ZSTD_createDCtx(), &ZSTD_freeDCtx);
  const std::size_t n = ZSTD_decompressDCtx(dctx.get(), out.data(), out.size(), in.data(), in.size());
  // Strata's words, not zstd's ("Data corruption detected"): what was expected of the bytes.
  if (ZSTD_isError(n))
    throw FormatError(file, field, "damaged zstd data: expected a zstd frame that decodes to the " +
                                       std::to_string(size) + " bytes it declares");
  if (n != size)
    throw FormatError(file, field, "damaged zstd data: the frame declares " + std::to_string(size) +
                                       " bytes but decodes to " + std::to_string(n));
}

}  // namespace strata::store
