#include "strata/lod/brick_provider.hpp"

#include <algorithm>
#include <chrono>
#include <unordered_set>

#include "strata/core/error.hpp"
#include "lod/payload_prefetcher.hpp"
#include "strata/lod/brick_decode.hpp"

namespace strata::lod {

namespace {

store::BrickKey parent_of(const store::BrickKey& k) {
  return {std::uint8_t(k.level + 1), k.x / 2, k.y / 2, k.z / 2};
}

// The rank a cut brick is reconstructed at: the frame's rank K (the rank slider), lowered to the
// rank a feature scale chose for it.
int brick_rank(const CutBrick& brick, int k) { return brick.rank > 0 ? std::min(brick.rank, k) : k; }

}  // namespace

BrickProvider::BrickProvider(const ta::TaVolume& volume, const ProviderOptions& options)
    : volume_(volume),
      cache_(options.cache_bytes),
      models_(options.model_cache_bytes),
      loader_([this](const LoadRequest& r, tensor::BrickReconstructor& rec, ta::DecodeScratch& s) { decode(r.key, rec, s); },
              options.loader_threads) {
  if (volume.container().source().remote()) prefetcher_ = std::make_unique<PayloadPrefetcher>(volume.container());
}

BrickProvider::~BrickProvider() = default;

int BrickProvider::clamp_rank(int k) const { return std::clamp(k, 1, volume_.rank()); }

ResidentBrick BrickProvider::constant_brick(const store::BrickEntry& entry, int rank) const {
  ResidentBrick r;
  r.key = entry.key;
  r.rank = rank;
  r.constant_value = entry.min;  // constant entries store their value as min == max
  return r;
}

BrickSamples BrickProvider::decode(const RankedKey& key, tensor::BrickReconstructor& reconstructor, ta::DecodeScratch& scratch) {
  const auto start = std::chrono::steady_clock::now();
  BrickModel model = models_.find(key.brick);
  if (!model) {
    std::uint64_t read = 0;
    model = fetch_model(volume_, volume_.entry(key.brick), scratch, read);
    bytes_read_ += read;
    models_.insert(key.brick, model);
  }
  const int b = volume_.geometry().layout().brick;
  auto samples = std::make_shared<std::vector<float>>(std::size_t(b) * b * b);
  reconstruct_at_rank(*model, key.rank, reconstructor, *samples);
  cache_.insert(key.brick, key.rank, samples);
  decode_ns_ += std::uint64_t(std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - start).count());
  return samples;
}

bool BrickProvider::stand_in(const CutBrick& brick, int rank, ResidentBrick& out, std::vector<LoadRequest>& requests) {
  int found = 0;
  // After a rank change the brick at its old rank is the closest picture of it.
  if (BrickSamples s = cache_.find_any_rank(brick.key, rank, &found)) {
    out = {brick.key, found, std::move(s), 0};
    return true;
  }
  const int top = volume_.geometry().level_count() - 1;
  store::BrickKey key = brick.key;
  while (key.level < top) {
    key = parent_of(key);
    const store::BrickEntry* entry = volume_.container().find(key);
    if (!entry) return false;
    if (entry->kind == store::PayloadKind::constant) {
      out = constant_brick(*entry, rank);
      return true;
    }
    if (BrickSamples s = cache_.find_any_rank(key, rank, &found)) {
      out = {key, found, std::move(s), 0};
      return true;
    }
    // Coarse bricks load first (queue order), so a cold start shows a coarse picture early.
    requests.push_back({{key, rank}, brick.depth});
  }
  // A cold start: nothing of this brick's line is resident. Its top-level ancestor (a handful
  // of bricks hold the whole volume there) is decoded now, so the first progressive frame shows
  // the volume coarsely instead of nothing until the loader catches up (a viewer's first
  // frame was black for 1.4-3.5 s).
  const store::BrickEntry* root = volume_.container().find(key);
  if (!root || root->kind == store::PayloadKind::constant) return false;
  out = {key, rank, decode({key, rank}, reconstructor_, scratch_), 0};
  return true;
}

void BrickProvider::submit(const std::vector<LoadRequest>& requests, bool wait_for_bytes) {
  // A remote file's payloads are fetched together first: a few coalesced range requests instead
  // of one round trip per brick on the loader threads (a 20 ms link made a first exact frame of
  // ~700 bricks take 13 s). An exact frame waits for them; a progressive one hands them to the
  // prefetcher's thread and draws at once. Local files fetch nothing.
  if (volume_.container().source().remote()) {
    std::vector<const store::BrickEntry*> entries;
    entries.reserve(requests.size());
    for (const LoadRequest& r : requests) entries.push_back(&volume_.entry(r.key.brick));
    if (wait_for_bytes)
      volume_.container().prefetch(entries);
    else
      prefetcher_->post(std::move(entries));
  }
  loader_.submit(requests);
}

void BrickProvider::resolve_exact(const Selection& cut, const std::vector<std::size_t>& missing, int k,
                                  std::vector<LoadRequest> requests, FrameBricks& frame) {
  submit(requests, true);
  loader_.drain(reconstructor_, scratch_);
  loader_.wait_idle();
  for (std::size_t i : missing) {
    const store::BrickKey& key = cut.bricks[i].key;
    const int rank = brick_rank(cut.bricks[i], k);
    BrickSamples s = cache_.find(key, rank);
    // Evicted already when the cache is smaller than the cut: decode again and keep our share.
    if (!s) s = decode({key, rank}, reconstructor_, scratch_);
    frame.bricks.push_back({key, rank, std::move(s), 0});
  }
}

FrameBricks BrickProvider::acquire(const Selection& cut, int rank, bool exact) {
  loader_.rethrow_failure();
  const int k = clamp_rank(rank);
  FrameBricks frame;
  LoadStats& st = frame.stats;
  st.selected = cut.bricks.size();
  std::vector<std::size_t> missing;
  std::vector<LoadRequest> requests;
  for (std::size_t i = 0; i < cut.bricks.size(); ++i) {
    const CutBrick& b = cut.bricks[i];
    const int rank = brick_rank(b, k);
    if (b.entry->kind == store::PayloadKind::constant) {
      frame.bricks.push_back(constant_brick(*b.entry, rank));
      ++st.cache_hits;  // resident by definition: nothing to decode
    } else if (BrickSamples s = cache_.find(b.key, rank)) {
      frame.bricks.push_back({b.key, rank, std::move(s), 0});
      ++st.cache_hits;
    } else {
      ++st.cache_misses;
      missing.push_back(i);
      requests.push_back({{b.key, rank}, b.depth});
    }
  }
  if (exact) {
    resolve_exact(cut, missing, k, std::move(requests), frame);
  } else {
    std::unordered_set<store::BrickKey, store::BrickKeyHash> shown;
    for (std::size_t i : missing) {
      ResidentBrick r;
      if (stand_in(cut.bricks[i], brick_rank(cut.bricks[i], k), r, requests) && shown.insert(r.key).second)
        frame.bricks.push_back(std::move(r));
    }
    submit(requests, false);
  }
  st.resident = frame.bricks.size();
  st.bytes_read = bytes_read_.exchange(0);
  st.decode_ms = double(decode_ns_.exchange(0)) * 1e-6;
  st.pending = loader_.queued() + loader_.running();
  return frame;
}

void BrickProvider::prefetch(const Selection& cut, int rank) {
  loader_.rethrow_failure();
  const int k = clamp_rank(rank);
  std::vector<LoadRequest> requests;
  for (const CutBrick& b : cut.bricks) {
    const int rank = brick_rank(b, k);
    if (b.entry->kind != store::PayloadKind::constant && !cache_.find(b.key, rank)) requests.push_back({{b.key, rank}, b.depth});
  }
  submit(requests, false);
}

void BrickProvider::wait_idle() { loader_.wait_idle(); }

}  // namespace strata::lod
