#pragma once
// Distributed label encoding (`strata-mpi labels encode`, docs/distributed.md): the ranks of an
// MPI communicator split the volume into z-ranges of whole 8-slice block rows and read only
// their own. Each gathers its label values (all-gathered into one label map), then maps its
// slices to source ids, building its part of level 0's id storage and of level 1 of the
// histogram mipmap with a table of its own. Rank 0 merges the parts in z order (re-interning
// each part's new mixtures reproduces the single-process table), builds the coarser levels,
// factorises and writes one .strata file equal to what mixture::encode_labels writes for the
// same options, timing fields aside.
#include <mpi.h>

#include <cstdint>
#include <filesystem>
#include <vector>

#include "strata/core/progress.hpp"
#include "strata/io/slab_stream.hpp"
#include "strata/io/volume_io.hpp"
#include "strata/mixture/encoded_labels.hpp"

namespace strata::dist {

/// @brief The level-0 slices rank `rank` of `ranks` encodes: contiguous runs of whole 8-slice
/// block rows in rank order, balanced by row count (a rank may have none).
io::SliceSpan label_slices_of(std::int64_t depth, int rank, int ranks);

/// @brief What one rank did.
struct LabelRankStats {
  std::int64_t z_begin = 0, z_end = 0;  // its level-0 slices
  std::uint64_t input_bytes = 0;        // bytes of the input it read (both passes)
  std::uint64_t part_bytes = 0;         // its part (level-0 ids, level-1 ids and mixtures) sent to rank 0
  std::uint64_t part_mixtures = 0;      // mixtures its slices made at level 1 (its local table)
  double values_seconds = 0, ids_seconds = 0;  // the label-value pass; the ids pass
  double merge_seconds = 0;  // rank 0: receiving and merging the parts; others: sending theirs
  double write_seconds = 0;  // rank 0: coarser levels, factorisation and the file
};

struct DistributedLabelsReport {
  mixture::EncodeReport report;  // on rank 0 as mixture::encode_labels reports it; elsewhere empty
  Extent dims;                   // of the input
  std::vector<LabelRankStats> ranks;  // on rank 0 every rank's, else only its own
};

/// @brief Collective over `comm`: encodes the label volume `input` into `out` (written by rank 0
/// as a temporary, renamed when complete). `options.memory_limit` bounds each rank's slabs as in
/// encode_labels; rank 0 also holds levels >= 1 of the whole mipmap, the table and the
/// factorisation. `options.normals` is refused (ParameterError: the normals need the whole
/// volume on one rank). Progress is reported on rank 0. Errors are agreed (agree()): all ranks
/// throw, none hangs, no file is left.
DistributedLabelsReport encode_labels_distributed(MPI_Comm comm, const std::filesystem::path& input,
                                                  const io::ReadOptions& read, const std::filesystem::path& out,
                                                  const mixture::EncodeOptions& options,
                                                  ProgressSink& progress = silent_progress());

}  // namespace strata::dist
