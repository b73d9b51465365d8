// The decode loops are written once and compiled for baseline x86-64, AVX2 and AVX-512 (like the
// reconstruction kernel): the log decoders evaluate a degree-7 polynomial per code, so with 4096
// core codes per brick the vector width decides whether decoding costs a third of the brick's
// reconstruction time or a tenth. `flatten` inlines the whole call tree into each variant, so
// the quantizers' inline decode() bodies are compiled for that variant's instruction set.
#include "decode_kernel.hpp"

#include <algorithm>
#include <bit>
#include <string>

#include "strata/core/error.hpp"
#include "strata/core/isa.hpp"
#include "strata/quant/bitpack.hpp"
#include "strata/quant/quantizers.hpp"

namespace strata::quant::detail {
namespace {

static_assert(std::endian::native == std::endian::little, "codes are stored little endian");

struct FloatBits {
  float operator()(std::uint32_t code) const { return std::bit_cast<float>(code); }
};

// Unpacks codes start .. start + count - 1 of a fixed width into 32-bit integers. Codes are
// staged like this, rather than decoded straight from the packed bytes, because a loop that
// reads bytes gets a vectorisation factor of 64 at 512-bit width, more than a K1 = 8 or 16 row
// holds, and would run its scalar epilogue only.
template <int Bits>
inline void unpack_run(const std::byte* stream, std::size_t start, std::size_t count, std::int32_t* codes) {
  if constexpr (Bits == 8) {
    const auto* p = reinterpret_cast<const std::uint8_t*>(stream) + start;
    for (std::size_t i = 0; i < count; ++i) codes[i] = p[i];
  } else if constexpr (Bits == 16 || Bits == 32) {
    using Word = std::conditional_t<Bits == 16, std::uint16_t, std::uint32_t>;
    const std::byte* p = stream + start * sizeof(Word);
    for (std::size_t i = 0; i < count; ++i) {
      Word w;
      __builtin_memcpy(&w, p + i * sizeof(Word), sizeof(Word));
      codes[i] = std::int32_t(w);
    }
  } else {
    static_assert(Bits == 12);  // two codes per three bytes
    std::size_t i = 0;
    if (start % 2 == 1 && count > 0) codes[i++] = std::int32_t(read_code(stream, 12, start));  // odd start
    const auto* p = reinterpret_cast<const std::uint8_t*>(stream) + (start + i) / 2 * 3;
    for (; i + 2 <= count; i += 2, p += 3) {
      codes[i] = std::int32_t(p[0]) | (std::int32_t(p[1] & 0x0F) << 8);
      codes[i + 1] = std::int32_t(p[1] >> 4) | (std::int32_t(p[2]) << 4);
    }
    if (i < count) codes[i] = std::int32_t(read_code(stream, 12, start + i));
  }
}

template <int Bits, class Decode>
inline void decode_run(const std::byte* stream, std::size_t start, std::size_t count, float* out, const Decode& decode) {
  constexpr std::size_t kChunk = 512;
  alignas(64) std::int32_t codes[kChunk];
  for (std::size_t done = 0; done < count; done += kChunk) {
    const std::size_t n = std::min(kChunk, count - done);
    unpack_run<Bits>(stream, start + done, n, codes);
    for (std::size_t i = 0; i < n; ++i) out[done + i] = decode(std::uint32_t(codes[i]));
  }
}

template <int Bits, class Decode>
inline void decode_rows(const DecodeJob& j, const Decode& decode) {
  float* out = j.out;
  for (int r3 = 0; r3 < j.rows3; ++r3)
    for (int r2 = 0; r2 < j.rows2; ++r2, out += j.count)
      decode_run<Bits>(j.stream, j.first + std::size_t(r2) * j.stride2 + std::size_t(r3) * j.stride3, j.count, out,
                       decode);
}

template <class Decode>
inline void decode_any_width(const DecodeJob& j, const Decode& decode) {
  switch (j.bits) {
    case 8: return decode_rows<8>(j, decode);
    case 12: return decode_rows<12>(j, decode);
    case 16: return decode_rows<16>(j, decode);
    case 32: return decode_rows<32>(j, decode);
    default: throw Error("decode: unsupported code width " + std::to_string(j.bits));
  }
}

// Quantizer objects are called as decoders: q(code) == q.decode(code).
template <class Q>
struct AsDecoder {
  Q q;
  float operator()(std::uint32_t code) const { return q.decode(code); }
};

inline void decode_any(const DecodeJob& j) {
  switch (j.coding) {
    case CoreCoding::f32: return decode_any_width(j, FloatBits{});
    case CoreCoding::linear: return decode_any_width(j, AsDecoder<LinearQuantizer>{{j.lo, j.hi, j.bits}});
    case CoreCoding::log: return decode_any_width(j, AsDecoder<LogQuantizer>{{j.max_abs, j.bits}});
    case CoreCoding::mulaw: return decode_any_width(j, AsDecoder<MuLawQuantizer>{{j.max_abs, j.mu, j.bits}});
  }
}

__attribute__((flatten)) void decode_generic(const DecodeJob& j) { decode_any(j); }
__attribute__((flatten)) STRATA_TARGET_AVX2 void decode_avx2(const DecodeJob& j) { decode_any(j); }
__attribute__((flatten)) STRATA_TARGET_AVX512 void decode_avx512(const DecodeJob& j) { decode_any(j); }

using DecodeFn = void (*)(const DecodeJob&);

// The widest variant active_isa() allows.
DecodeFn decoder_for(Isa isa) {
  switch (isa) {
    case Isa::avx512: return decode_avx512;
    case Isa::avx2: return decode_avx2;
    default: return decode_generic;
  }
}

// Rows that follow each other in the stream (K1 = R1, and then K2 = R2) merge into one long run.
DecodeJob merge_contiguous_rows(DecodeJob j) {
  if (j.rows2 > 1 && j.stride2 == j.count) {
    j.count *= std::size_t(j.rows2);
    j.stride2 = 0;
    j.rows2 = 1;
  }
  if (j.rows2 == 1 && j.rows3 > 1 && j.stride3 == j.count) {
    j.count *= std::size_t(j.rows3);
    j.stride3 = 0;
    j.rows3 = 1;
  }
  return j;
}

}  // namespace

void decode_codes(const DecodeJob& job) {
  const DecodeFn decode = decoder_for(active_isa());
  decode(merge_contiguous_rows(job));
}

}  // namespace strata::quant::detail
