#pragma once
/// @file
/// @brief What the ray caster asks for each frame: the bricks of a LOD cut, reconstructed at rank K.
/// Resident bricks are handed out at once; misses go to the asynchronous loader and, until they
/// arrive, the nearest resident stand-in is drawn (the same brick at another rank, else its
/// nearest resident ancestor), so a frame never waits (paper 1, §3 and §6.1). In exact mode the
/// frame waits for every miss and the calling thread decodes alongside the loader.
///
/// A stand-in ancestor covers the region of several cut bricks and may overlap cut bricks that
/// are resident; the sampler should prefer the finest brick that covers a point.
#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "strata/lod/brick_cache.hpp"
#include "strata/lod/brick_loader.hpp"
#include "strata/lod/frame_bricks.hpp"
#include "strata/lod/model_cache.hpp"
#include "strata/lod/selection.hpp"
#include "strata/ta/ta_volume.hpp"

namespace strata::lod {

class PayloadPrefetcher;  // src/lod/payload_prefetcher.hpp

/// @brief Cache budgets and loader threads of a BrickProvider.
struct ProviderOptions {
  std::uint64_t cache_bytes = 1ull << 30;        // reconstructed bricks; should hold a whole cut
  std::uint64_t model_cache_bytes = 256ull << 20;  // dequantized models (the rank slider's source)
  int loader_threads = 0;                          // 0 = default_loader_threads()
};

/// @brief The bricks of each frame of one TA volume (see the file comment).
class BrickProvider {
 public:
  /// @brief `volume` must outlive the provider.
  explicit BrickProvider(const ta::TaVolume& volume, const ProviderOptions& options = {});
  ~BrickProvider();
  BrickProvider(const BrickProvider&) = delete;
  BrickProvider& operator=(const BrickProvider&) = delete;

  /// @brief The bricks for one frame at rank K (clamped to 1..stored rank; a cut brick with a rank of its
  /// own, chosen by a feature scale, is reconstructed at the lower of the two). Progressive (exact = false):
  /// never blocks on a miss. Exact: returns every cut brick itself. One caller at a time.
  /// Rethrows a loader failure (e.g. a corrupt payload) from an earlier request.
  /// stats.bytes_read and stats.decode_ms count the loading finished since the previous call, by
  /// the loader threads and (exact mode) this thread; hits and misses count cut bricks only
  /// (constant bricks are hits: they need no decode).
  FrameBricks acquire(const Selection& cut, int rank, bool exact);

  /// @brief Queues the cut's missing bricks at rank K on the loader and returns at once (a viewer's
  /// guess at what it shows next); the loading counts in the next acquire's stats.
  void prefetch(const Selection& cut, int rank);

  /// @brief Blocks until the loader has nothing queued or running (tests, --exact batch rendering).
  void wait_idle();

  /// @brief K clamped to 1..the volume's stored rank.
  int clamp_rank(int k) const;
  const BrickCache& cache() const { return cache_; }
  const ModelCache& models() const { return models_; }

 private:
  // Queues `requests` on the loader; a remote file's payloads are fetched in bulk first, waited
  // for or in the background (src/lod/payload_prefetcher.hpp).
  void submit(const std::vector<LoadRequest>& requests, bool wait_for_bytes);
  BrickSamples decode(const RankedKey& key, tensor::BrickReconstructor& reconstructor, ta::DecodeScratch& scratch);
  ResidentBrick constant_brick(const store::BrickEntry& entry, int rank) const;
  // The nearest resident stand-in for a missing brick, if any; queues missing ancestors so the
  // next frames have coarse data early (BrickLoader::submit drops repeated requests).
  bool stand_in(const CutBrick& brick, int rank, ResidentBrick& out, std::vector<LoadRequest>& requests);
  void resolve_exact(const Selection& cut, const std::vector<std::size_t>& missing, int k,
                     std::vector<LoadRequest> requests, FrameBricks& frame);

  const ta::TaVolume& volume_;
  BrickCache cache_;
  ModelCache models_;
  std::atomic<std::uint64_t> bytes_read_{0}, decode_ns_{0};  // since the last acquire
  tensor::BrickReconstructor reconstructor_;  // the calling thread's, for exact frames
  ta::DecodeScratch scratch_;
  std::unique_ptr<PayloadPrefetcher> prefetcher_;  // remote files only
  BrickLoader loader_;  // last: its threads stop before the caches go
};

}  // namespace strata::lod
