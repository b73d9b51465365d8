#include "strata/mixture/id_storage.hpp"

#include <algorithm>
#include <bit>
#include <cstring>
#include <map>
#include <string>

#include "strata/core/bytes.hpp"
#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"
#include "strata/quant/bitpack.hpp"

namespace strata::mixture {

namespace {

static_assert(std::endian::native == std::endian::little, "id storage layout assumes a little-endian host");

int bits_for(std::uint64_t distinct_values) {  // ceil(log2(n)), 0 for n <= 1
  return distinct_values <= 1 ? 0 : int(std::bit_width(distinct_values - 1));
}

void check_ids(std::span<const std::uint32_t> ids, const Extent& dims, const char* what) {
  if (dims.x < 1 || dims.y < 1 || dims.z < 1 || std::int64_t(ids.size()) != dims.voxel_count())
    throw Error(std::string(what) + ": " + std::to_string(ids.size()) + " ids for dims " + dims.to_string());
}

constexpr std::uint8_t kFixedTag = 1, kBlockTag = 2;

Extent block_grid(const Extent& dims) {
  const std::int64_t b = BlockPaletteIds::kBlock;
  return {(dims.x + b - 1) / b, (dims.y + b - 1) / b, (dims.z + b - 1) / b};
}

Extent read_dims(ByteReader& r) {
  Extent d;
  d.x = r.get<std::int64_t>("dims");
  d.y = r.get<std::int64_t>("dims");
  d.z = r.get<std::int64_t>("dims");
  if (d.x < 1 || d.y < 1 || d.z < 1 || d.x > (1 << 24) || d.y > (1 << 24) || d.z > (1 << 24))
    throw FormatError(r.file(), "dims", "invalid extents " + d.to_string());
  return d;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// FixedRateIds

FixedRateIds::FixedRateIds(std::span<const std::uint32_t> ids, const Extent& dims) {
  check_ids(ids, dims, "FixedRateIds");
  const auto [lo, hi] = std::minmax_element(ids.begin(), ids.end());
  Builder b(dims, *lo, *hi);
  b.append(ids);
  *this = b.finish();
}

FixedRateIds::Builder::Builder(const Extent& dims, std::uint32_t min_id, std::uint32_t max_id) : max_(max_id) {
  if (dims.x < 1 || dims.y < 1 || dims.z < 1) throw Error("FixedRateIds: invalid dims " + dims.to_string());
  if (max_id < min_id)
    throw Error("FixedRateIds: id range [" + std::to_string(min_id) + ", " + std::to_string(max_id) + "] is empty");
  out_.dims_ = dims;
  out_.min_ = min_id;
  out_.bits_ = bits_for(std::uint64_t(max_id) - min_id + 1);
  if (out_.bits_ > 0) out_.packed_.reserve(quant::packed_size(std::size_t(dims.voxel_count()), out_.bits_));
}

void FixedRateIds::Builder::append(std::span<const std::uint32_t> ids) {
  if (count_ + ids.size() > std::uint64_t(out_.dims_.voxel_count()))
    throw Error("FixedRateIds: more than " + std::to_string(out_.dims_.voxel_count()) + " ids for dims " +
                out_.dims_.to_string());
  for (const std::uint32_t id : ids)
    if (id < out_.min_ || id > max_)
      throw Error("FixedRateIds: id " + std::to_string(id) + " outside the declared range [" + std::to_string(out_.min_) +
                  ", " + std::to_string(max_) + "]");
  count_ += ids.size();
  if (out_.bits_ == 0) return;
  // Ids are packed 8 at a time (8 codes fill whole bytes), so the runs need not be aligned.
  if (!pending_.empty()) {
    const std::size_t take = std::min(ids.size(), 8 - pending_.size());
    pending_.insert(pending_.end(), ids.begin(), ids.begin() + std::ptrdiff_t(take));
    ids = ids.subspan(take);
    if (pending_.size() < 8) return;
    pack(pending_);
    pending_.clear();
  }
  const std::size_t whole = ids.size() / 8 * 8;
  pack(ids.first(whole));
  pending_.assign(ids.begin() + std::ptrdiff_t(whole), ids.end());
}

void FixedRateIds::Builder::append_part(const FixedRateIds& part) {
  const std::uint64_t n = std::uint64_t(part.dims_.voxel_count());
  if (!pending_.empty() || part.dims_.x != out_.dims_.x || part.dims_.y != out_.dims_.y || part.min_ != out_.min_ ||
      part.bits_ != out_.bits_ || count_ + n > std::uint64_t(out_.dims_.voxel_count()))
    throw Error("FixedRateIds: a part of dims " + part.dims_.to_string() + " at " + std::to_string(part.bits_) +
                " bits does not continue " + std::to_string(count_) + " ids of dims " + out_.dims_.to_string() +
                " at " + std::to_string(out_.bits_) + " bits");
  count_ += n;
  out_.packed_.insert(out_.packed_.end(), part.packed_.begin(), part.packed_.end());
}

void FixedRateIds::Builder::pack(std::span<const std::uint32_t> ids) {
  codes_.resize(ids.size());
  for (std::size_t i = 0; i < ids.size(); ++i) codes_[i] = ids[i] - out_.min_;
  const std::size_t start = out_.packed_.size();
  out_.packed_.resize(start + quant::packed_size(codes_.size(), out_.bits_));
  quant::pack_codes(codes_, out_.bits_, std::span(out_.packed_).subspan(start));
}

FixedRateIds FixedRateIds::Builder::finish() {
  if (count_ != std::uint64_t(out_.dims_.voxel_count()))
    throw Error("FixedRateIds: " + std::to_string(count_) + " ids for dims " + out_.dims_.to_string());
  if (!pending_.empty()) pack(pending_);
  pending_.clear();
  return std::move(out_);
}

std::uint32_t FixedRateIds::at(std::int64_t x, std::int64_t y, std::int64_t z) const {
  if (bits_ == 0) return min_;
  return min_ + quant::read_code(packed_.data(), bits_, std::size_t((z * dims_.y + y) * dims_.x + x));
}

std::vector<std::byte> FixedRateIds::serialize() const {
  ByteWriter w(byte_size());
  w.put(kFixedTag);
  w.put(dims_.x);
  w.put(dims_.y);
  w.put(dims_.z);
  w.put(min_);
  w.put(std::uint8_t(bits_));
  w.put(std::uint64_t(packed_.size()));
  w.put_bytes(packed_);
  return w.take();
}

FixedRateIds FixedRateIds::deserialize(std::span<const std::byte> bytes) {
  ByteReader r(bytes, "fixed-rate ids");
  if (r.get<std::uint8_t>("tag") != kFixedTag) throw FormatError(r.file(), "tag", "not a fixed-rate id stream");
  FixedRateIds f;
  f.dims_ = read_dims(r);
  f.min_ = r.get<std::uint32_t>("min");
  f.bits_ = r.get<std::uint8_t>("bits");
  if (f.bits_ > 32) throw FormatError(r.file(), "bits", "more than 32");
  const auto n = r.get<std::uint64_t>("size");
  if (n != quant::packed_size(std::size_t(f.dims_.voxel_count()), f.bits_) && !(f.bits_ == 0 && n == 0))
    throw FormatError(r.file(), "size", "packed length does not match dims and bits");
  auto b = r.bytes(n, "codes");
  f.packed_.assign(b.begin(), b.end());
  return f;
}

// ---------------------------------------------------------------------------------------------
// BlockPaletteIds

BlockPaletteIds::BlockPaletteIds(std::span<const std::uint32_t> ids, const Extent& dims) {
  check_ids(ids, dims, "BlockPaletteIds");
  Builder b(dims);
  b.append(ids);
  *this = b.finish();
}

BlockPaletteIds::Builder::Builder(const Extent& dims) {
  if (dims.x < 1 || dims.y < 1 || dims.z < 1) throw Error("BlockPaletteIds: invalid dims " + dims.to_string());
  out_.dims_ = dims;
  out_.grid_ = block_grid(dims);
  out_.blocks_.resize(std::size_t(out_.grid_.voxel_count()));
}

void BlockPaletteIds::Builder::append(std::span<const std::uint32_t> ids) {
  const Extent& d = out_.dims_;
  const std::size_t slice = std::size_t(d.x * d.y);
  if (ids.size() % slice != 0 || slices_ + std::int64_t(ids.size() / slice) > d.z)
    throw Error("BlockPaletteIds: " + std::to_string(ids.size()) + " ids after " + std::to_string(slices_) +
                " slices are not whole slices within dims " + d.to_string());
  slices_ += std::int64_t(ids.size() / slice);
  const std::size_t row = slice * kBlock;  // ids of one block row
  if (!pending_.empty()) {
    const std::size_t take = std::min(ids.size(), row - pending_.size());
    pending_.insert(pending_.end(), ids.begin(), ids.begin() + std::ptrdiff_t(take));
    ids = ids.subspan(take);
    if (pending_.size() < row && slices_ < d.z) return;
    encode_block_row(pending_);
    pending_.clear();
  }
  while (ids.size() >= row) {
    encode_block_row(ids.first(row));
    ids = ids.subspan(row);
  }
  if (ids.empty()) return;
  if (slices_ == d.z) {
    encode_block_row(ids);  // the last, shorter block row
  } else {
    pending_.assign(ids.begin(), ids.end());
  }
}

void BlockPaletteIds::Builder::append_part(const BlockPaletteIds& part) {
  const Extent& d = out_.dims_;
  const bool fits = part.dims_.x == d.x && part.dims_.y == d.y && slices_ + part.dims_.z <= d.z;
  if (!pending_.empty() || slices_ % kBlock != 0 || !fits ||
      (part.dims_.z % kBlock != 0 && slices_ + part.dims_.z != d.z))
    throw Error("BlockPaletteIds: a part of dims " + part.dims_.to_string() + " does not continue " +
                std::to_string(slices_) + " slices of dims " + d.to_string() + " in whole block rows");
  std::vector<std::uint32_t> palette;
  BlockHeader* h = out_.blocks_.data() + block_rows_ * out_.grid_.y * out_.grid_.x;
  for (const BlockHeader& b : part.blocks_) {
    palette.assign(part.palettes_.begin() + b.palette_offset, part.palettes_.begin() + b.palette_offset + b.palette_size);
    auto [it, inserted] = palette_offsets_.emplace(palette, std::uint32_t(out_.palettes_.size()));
    if (inserted) out_.palettes_.insert(out_.palettes_.end(), palette.begin(), palette.end());
    *h = b;
    h->palette_offset = it->second;
    h->bit_offset = std::uint64_t(out_.indices_.size()) * 8;
    if (b.bits > 0) {
      const auto from = part.indices_.begin() + std::ptrdiff_t(b.bit_offset / 8);
      out_.indices_.insert(out_.indices_.end(), from,
                           from + std::ptrdiff_t(quant::packed_size(std::size_t(kBlock * kBlock * kBlock), b.bits)));
    }
    ++h;
  }
  slices_ += part.dims_.z;
  block_rows_ += part.grid_.z;
}

void BlockPaletteIds::Builder::encode_block_row(std::span<const std::uint32_t> slices) {
  const Extent& dims = out_.dims_;
  const Extent& grid = out_.grid_;
  const std::int64_t b = kBlock;
  const std::int64_t depth = std::int64_t(slices.size() / std::size_t(dims.x * dims.y));
  const std::int64_t bz = block_rows_++;
  const std::int64_t blocks = grid.y * grid.x;
  row_.resize(std::size_t(blocks));
  // Palettes and packed indices of the row's blocks in parallel; the palettes are then
  // deduplicated and the indices appended in block order, so the bytes do not depend on threads.
#pragma omp parallel num_threads(thread_count())
  {
    std::vector<std::uint32_t> block_ids(std::size_t(b * b * b)), codes(block_ids.size());
#pragma omp for schedule(dynamic, 16)
    for (std::int64_t k = 0; k < blocks; ++k) {
      const std::int64_t by = k / grid.x, bx = k % grid.x;
      // Gather the block (edge blocks repeat their last voxel so every block has b^3 entries).
      for (std::int64_t kz = 0; kz < b; ++kz)
        for (std::int64_t j = 0; j < b; ++j)
          for (std::int64_t i = 0; i < b; ++i) {
            const std::int64_t x = std::min(bx * b + i, dims.x - 1), y = std::min(by * b + j, dims.y - 1),
                               z = std::min(kz, depth - 1);
            block_ids[std::size_t((kz * b + j) * b + i)] = slices[std::size_t((z * dims.y + y) * dims.x + x)];
          }
      EncodedBlock& e = row_[std::size_t(k)];
      e.palette = block_ids;
      std::sort(e.palette.begin(), e.palette.end());
      e.palette.erase(std::unique(e.palette.begin(), e.palette.end()), e.palette.end());
      const int bits = bits_for(e.palette.size());
      e.indices.clear();
      if (bits == 0) continue;
      for (std::size_t v = 0; v < block_ids.size(); ++v)
        codes[v] = std::uint32_t(std::lower_bound(e.palette.begin(), e.palette.end(), block_ids[v]) - e.palette.begin());
      e.indices.resize(quant::packed_size(codes.size(), bits));
      quant::pack_codes(codes, bits, std::span<std::byte>(e.indices));
    }
  }
  for (std::int64_t k = 0; k < blocks; ++k) {
    const EncodedBlock& e = row_[std::size_t(k)];
    BlockHeader& h = out_.blocks_[std::size_t(bz * blocks + k)];
    auto [it, inserted] = palette_offsets_.emplace(e.palette, std::uint32_t(out_.palettes_.size()));
    if (inserted) out_.palettes_.insert(out_.palettes_.end(), e.palette.begin(), e.palette.end());
    h.palette_offset = it->second;
    h.palette_size = std::uint32_t(e.palette.size());
    h.bits = std::uint8_t(bits_for(e.palette.size()));
    h.bit_offset = std::uint64_t(out_.indices_.size()) * 8;
    out_.indices_.insert(out_.indices_.end(), e.indices.begin(), e.indices.end());
  }
}

BlockPaletteIds BlockPaletteIds::Builder::finish() {
  if (slices_ != out_.dims_.z || !pending_.empty())
    throw Error("BlockPaletteIds: " + std::to_string(slices_) + " slices for dims " + out_.dims_.to_string());
  out_.indices_.resize(out_.indices_.size() + kIndexPadding);
  palette_offsets_.clear();
  row_ = {};
  return std::move(out_);
}

const BlockPaletteIds::BlockHeader& BlockPaletteIds::block_of(std::int64_t x, std::int64_t y, std::int64_t z) const {
  return blocks_[std::size_t(((z / kBlock) * grid_.y + y / kBlock) * grid_.x + x / kBlock)];
}

std::uint32_t BlockPaletteIds::index_in_block(const BlockHeader& b, std::int64_t x, std::int64_t y,
                                              std::int64_t z) const {
  if (b.bits == 0) return 0;
  const std::size_t local = std::size_t(((z % kBlock) * kBlock + y % kBlock) * kBlock + x % kBlock);
  return quant::read_code(indices_.data() + b.bit_offset / 8, b.bits, local);
}

std::uint32_t BlockPaletteIds::at(std::int64_t x, std::int64_t y, std::int64_t z) const {
  const BlockHeader& b = block_of(x, y, z);
  return palettes_[b.palette_offset + index_in_block(b, x, y, z)];
}

void BlockPaletteIds::decode_box(const Box& box, std::span<std::uint32_t> out) const {
  if (box.empty() || !Box::whole(dims_).contains(box))
    throw Error("BlockPaletteIds::decode_box: " + box.to_string() + " is not inside " + dims_.to_string());
  const Extent s = box.size();
  if (out.size() != std::size_t(s.voxel_count()))
    throw Error("BlockPaletteIds::decode_box: " + std::to_string(out.size()) + " outputs for " + box.to_string());
  for (std::int64_t z = box.lo.z; z < box.hi.z; ++z)
    for (std::int64_t y = box.lo.y; y < box.hi.y; ++y) {
      std::uint32_t* row = out.data() + ((z - box.lo.z) * s.y + (y - box.lo.y)) * s.x - box.lo.x;
      // The 8 indices of one block row are 8 * bits bits = `bits` whole bytes, starting on a
      // byte: row r of a block begins at byte r * bits of the block's indices.
      const std::size_t block_row = std::size_t((z % kBlock) * kBlock + y % kBlock);
      for (std::int64_t x = box.lo.x; x < box.hi.x;) {
        const BlockHeader& b = block_of(x, y, z);
        const std::int64_t run_end = std::min(box.hi.x, (x / kBlock + 1) * kBlock);
        const std::uint32_t* palette = palettes_.data() + b.palette_offset;
        if (b.bits == 0) {
          std::fill(row + x, row + run_end, palette[0]);
        } else if (b.bits <= 8) {
          // The whole block row in one little-endian word: 8 bytes are read (the store keeps
          // kIndexPadding bytes after the last block), the bytes past the row never shifted in.
          std::uint64_t word;
          std::memcpy(&word, indices_.data() + b.bit_offset / 8 + block_row * b.bits, sizeof word);
          const unsigned bits = b.bits;
          const std::uint64_t mask = (std::uint64_t(1) << bits) - 1;
          for (std::int64_t i = x; i < run_end; ++i) row[i] = palette[(word >> (unsigned(i % kBlock) * bits)) & mask];
        } else {
          for (std::int64_t i = x; i < run_end; ++i) row[i] = palette[index_in_block(b, i, y, z)];
        }
        x = run_end;
      }
    }
}

std::size_t BlockPaletteIds::byte_size() const {
  return 1 + 3 * 8 + 3 * 8 + blocks_.size() * 17 + palettes_.size() * 4 + index_bytes();
}

std::vector<std::byte> BlockPaletteIds::serialize() const {
  ByteWriter w(byte_size());
  w.put(kBlockTag);
  w.put(dims_.x);
  w.put(dims_.y);
  w.put(dims_.z);
  w.put(std::uint64_t(blocks_.size()));
  w.put(std::uint64_t(palettes_.size()));
  w.put(std::uint64_t(index_bytes()));
  for (const BlockHeader& b : blocks_) {
    w.put(b.palette_offset);
    w.put(b.palette_size);
    w.put(b.bit_offset);
    w.put(b.bits);
  }
  for (std::uint32_t p : palettes_) w.put(p);
  w.put_bytes(std::span(indices_).first(index_bytes()));
  return w.take();
}

BlockPaletteIds BlockPaletteIds::deserialize(std::span<const std::byte> bytes) {
  ByteReader r(bytes, "block-palette ids");
  if (r.get<std::uint8_t>("tag") != kBlockTag) throw FormatError(r.file(), "tag", "not a block-palette id stream");
  BlockPaletteIds s;
  s.dims_ = read_dims(r);
  const std::int64_t b = kBlock;
  s.grid_ = block_grid(s.dims_);
  const auto nblocks = r.get<std::uint64_t>("blocks"), npalette = r.get<std::uint64_t>("palette size"),
             nindex = r.get<std::uint64_t>("index size");
  if (nblocks != std::uint64_t(s.grid_.voxel_count())) throw FormatError(r.file(), "blocks", "count does not match dims");
  r.need_array(nblocks, 17, "block headers");
  s.blocks_.resize(std::size_t(nblocks));
  for (BlockHeader& h : s.blocks_) {
    h.palette_offset = r.get<std::uint32_t>("block headers");
    h.palette_size = r.get<std::uint32_t>("block headers");
    h.bit_offset = r.get<std::uint64_t>("block headers");
    h.bits = r.get<std::uint8_t>("block headers");
  }
  r.need_array(npalette, 4, "palettes");
  s.palettes_.resize(std::size_t(npalette));
  for (auto& p : s.palettes_) p = r.get<std::uint32_t>("palettes");
  auto idx = r.bytes(nindex, "indices");
  s.indices_.assign(idx.begin(), idx.end());
  s.indices_.resize(s.indices_.size() + kIndexPadding);
  // Validate every block so at() never reads out of bounds.
  const std::size_t block_voxels = std::size_t(b * b * b);
  for (const BlockHeader& h : s.blocks_) {
    if (h.palette_size == 0 || std::uint64_t(h.palette_offset) + h.palette_size > npalette || h.bits > 32 ||
        h.bits != bits_for(h.palette_size) || h.bit_offset % 8 != 0 ||
        h.bit_offset / 8 + quant::packed_size(block_voxels, h.bits) > nindex)
      throw FormatError(r.file(), "blocks", "a block header is inconsistent");
  }
  return s;
}

}  // namespace strata::mixture
