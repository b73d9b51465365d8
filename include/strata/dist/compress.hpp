#pragma once
// Distributed compression (`strata-mpi compress`, docs/distributed.md): the ranks of an MPI
// communicator split every level of the octree into contiguous ranges of brick rows, read only
// the input slices of their rows, exchange the decoded slices the next coarser level needs, and
// rank 0 writes one .strata file, byte-identical to what ta::compress_volume writes for the same
// parameters (fixed-rank ta-bricked codec).
#include <mpi.h>

#include <cstdint>
#include <exception>
#include <filesystem>
#include <utility>
#include <vector>

#include "strata/core/error.hpp"
#include "strata/dist/agree.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/ta/compress.hpp"
#include "strata/ta/octree.hpp"

namespace strata::dist {


/// @brief Brick rows [begin, end) of one level.
struct RowRange {
  std::int64_t begin = 0, end = 0;
  bool empty() const { return begin >= end; }
};

/// @brief The rows of `level` that rank `rank` of `ranks` encodes: contiguous ranges in rank
/// order, balanced by row count (a rank may have none at coarse levels). With an odd core width
/// ranges start at even rows, so that each 2x2x2 block of the next level lies in one range.
RowRange rows_of(const ta::OctreeGeometry& geometry, int level, int rank, int ranks);

/// @brief The order in which ta::compress_volume's level pipelines finish brick rows (level,
/// row): the order of the bricks in its file (within a row, x fastest then y).
std::vector<std::pair<int, std::int64_t>> row_order(const ta::OctreeGeometry& geometry);

/// @brief What one rank did.
struct RankStats {
  std::uint64_t input_bytes = 0;     // bytes of the input it read (range scan and encoding pass)
  std::uint64_t sent_bytes = 0;      // decoded slices sent to other ranks (all levels)
  std::uint64_t received_bytes = 0;  // decoded slices received from other ranks
  std::uint64_t payload_bytes = 0;   // encoded bricks (what it hands to rank 0 for the file)
  std::int64_t level0_rows = 0, bricks = 0;
  double scan_seconds = 0, encode_seconds = 0, exchange_seconds = 0, write_seconds = 0;
};

struct DistributedReport {
  ta::CompressReport report;     // on rank 0 as ta::compress_volume reports it; elsewhere partial
  std::vector<RankStats> ranks;  // on rank 0 every rank's, else only its own
};

/// @brief Collective over `comm`: compresses `input` into `out` (written by rank 0 as
/// `<out>.tmp`, renamed when complete). Fixed-rank ta-bricked only (ParameterError otherwise:
/// the error targets' calibration and HOSVD probing and ta-global's whole-volume fit depend on
/// all earlier rows). Errors are agreed (agree()): all ranks throw, none hangs, no file is left.
DistributedReport compress_distributed(MPI_Comm comm, const std::filesystem::path& input, const io::ReadOptions& read,
                                       const std::filesystem::path& out, const ta::CompressParams& params);

}  // namespace strata::dist
