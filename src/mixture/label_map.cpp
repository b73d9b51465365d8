#include "strata/mixture/label_map.hpp"

#include <omp.h>

#include <algorithm>
#include <iterator>
#include <limits>
#include <string>
#include <type_traits>

#include "strata/core/error.hpp"
#include "strata/core/threads.hpp"
#include "strata/mixture/flat_hash.hpp"

namespace strata::mixture {

namespace {

constexpr std::int64_t kNoValue = std::numeric_limits<std::int64_t>::min();

struct I64Hash {
  std::uint64_t operator()(std::int64_t k) const { return splitmix64(std::uint64_t(k)); }
};

template <class T>
constexpr bool kPresenceTable = sizeof(T) <= 2;  // dtypes of <= 16 bits: a table indexed by the value

template <class T>
constexpr std::size_t presence_range() {
  return std::size_t(std::int64_t(std::numeric_limits<T>::max()) - std::int64_t(std::numeric_limits<T>::min()) + 1);
}

// Small dtypes: marks every value of `s` in `seen` (presence_range<T>() entries).
template <class T>
void mark_values(std::span<const T> s, std::vector<unsigned char>& seen) {
  constexpr std::int64_t lo = std::numeric_limits<T>::min();
  constexpr std::size_t range = presence_range<T>();
  const int nt = thread_count();
  std::vector<std::vector<unsigned char>> local(std::size_t(nt), std::vector<unsigned char>(range, 0));
#pragma omp parallel for num_threads(nt) schedule(static)
  for (std::int64_t i = 0; i < std::int64_t(s.size()); ++i)
    local[std::size_t(omp_get_thread_num())][std::size_t(std::int64_t(s[std::size_t(i)]) - lo)] = 1;
  for (const auto& l : local)
    for (std::size_t v = 0; v < range; ++v) seen[v] |= l[v];
}

// Wide dtypes: the distinct values of `s`, sorted.
template <class T>
std::vector<std::int64_t> distinct_values(std::span<const T> s) {
  const int nt = thread_count();
  std::vector<std::vector<std::int64_t>> local(static_cast<std::size_t>(nt));
#pragma omp parallel num_threads(nt)
  {
    detail::FlatMap<std::int64_t, char, I64Hash> set(kNoValue);
    const std::int64_t n = std::int64_t(s.size());
    const int t = omp_get_thread_num(), T_ = omp_get_num_threads();
    const std::int64_t b = n * t / T_, e = n * (t + 1) / T_;
    std::int64_t last = kNoValue;
    for (std::int64_t i = b; i < e; ++i) {
      const std::int64_t v = std::int64_t(s[std::size_t(i)]);
      if (v == last) continue;
      last = v;
      set.insert(v, 0);
    }
    auto& out = local[std::size_t(t)];
    set.for_each([&](std::int64_t k, char) { out.push_back(k); });
  }
  std::vector<std::int64_t> values;
  for (auto& l : local) values.insert(values.end(), l.begin(), l.end());
  std::sort(values.begin(), values.end());
  values.erase(std::unique(values.begin(), values.end()), values.end());
  return values;
}

[[noreturn]] void throw_unmapped(std::int64_t value) {
  throw Error("label map: value " + std::to_string(value) +
              " is not among the labels of the first pass (did the input change while it was read?)");
}

template <class T>
void assign_ids(std::span<const T> s, std::span<const std::int64_t> values, std::vector<std::uint32_t>& ids) {
  ids.resize(s.size());
  constexpr std::uint32_t kMissing = ~0u;
  bool missing = false;
  if constexpr (kPresenceTable<T>) {
    constexpr std::int64_t lo = std::numeric_limits<T>::min();
    std::vector<std::uint32_t> table(presence_range<T>(), kMissing);
    for (std::size_t i = 0; i < values.size(); ++i) table[std::size_t(values[i] - lo)] = std::uint32_t(i);
#pragma omp parallel for num_threads(thread_count()) schedule(static) reduction(|| : missing)
    for (std::int64_t i = 0; i < std::int64_t(s.size()); ++i) {
      const std::uint32_t id = table[std::size_t(std::int64_t(s[std::size_t(i)]) - lo)];
      missing = missing || id == kMissing;
      ids[std::size_t(i)] = id;
    }
  } else {
#pragma omp parallel num_threads(thread_count()) reduction(|| : missing)
    {
      const std::int64_t n = std::int64_t(s.size());
      const int t = omp_get_thread_num(), T_ = omp_get_num_threads();
      const std::int64_t b = n * t / T_, e = n * (t + 1) / T_;
      std::int64_t last = kNoValue;
      std::uint32_t last_id = 0;
      for (std::int64_t i = b; i < e; ++i) {
        const std::int64_t v = std::int64_t(s[std::size_t(i)]);
        if (v != last) {
          last = v;
          const auto it = std::lower_bound(values.begin(), values.end(), v);
          missing = missing || it == values.end() || *it != v;
          last_id = std::uint32_t(it - values.begin());
        }
        ids[std::size_t(i)] = last_id;
      }
    }
  }
  if (!missing) return;
  for (const T v : s)
    if (!std::binary_search(values.begin(), values.end(), std::int64_t(v))) throw_unmapped(std::int64_t(v));
}

void require_integer(DType dtype) {
  if (!dtype_is_integer(dtype))
    throw Error("mixture: label volume must have an integer dtype, got " + std::string(dtype_name(dtype)));
}

}  // namespace

LabelMap::LabelMap(DType dtype, std::vector<std::int64_t> values) : dtype_(dtype), values_(std::move(values)) {
  if (!dtype_is_integer(dtype)) throw Error("label map: dtype " + std::string(dtype_name(dtype)) + " is not an integer type");
  for (std::size_t i = 1; i < values_.size(); ++i)
    if (values_[i - 1] >= values_[i]) throw Error("label map: values must be strictly increasing");
  // Every value must survive the cast to the sample type in decode(): sorted, so the ends decide.
  visit_dtype(dtype_, [&](auto tag) {
    using T = decltype(tag);
    if constexpr (std::is_integral_v<T>) {
      // Values are kept as int64: u64 ids up to 2^63 - 1 (no segmentation reaches beyond).
      constexpr std::uint64_t kMax = std::uint64_t(std::numeric_limits<T>::max());
      const std::int64_t lo = std::numeric_limits<T>::min(),
                         hi = kMax > std::uint64_t(INT64_MAX) ? INT64_MAX : std::int64_t(kMax);
      for (const std::int64_t v : {values_.empty() ? 0 : values_.front(), values_.empty() ? 0 : values_.back()})
        if (v < lo || v > hi)
          throw Error("label map: value " + std::to_string(v) + " does not fit the sample type " + std::string(dtype_name(dtype_)) +
                      " (" + std::to_string(lo) + ".." + std::to_string(hi) + ")");
    }
  });
  if (values_.size() > std::numeric_limits<std::uint32_t>::max() - 1)
    throw Error("label map: more than 2^32 - 2 distinct labels");
}

std::optional<std::uint32_t> LabelMap::id_of(std::int64_t value) const {
  auto it = std::lower_bound(values_.begin(), values_.end(), value);
  if (it == values_.end() || *it != value) return std::nullopt;
  return std::uint32_t(it - values_.begin());
}

Volume LabelMap::decode(std::span<const std::uint32_t> ids, Extent dims, Spacing spacing) const {
  if (std::int64_t(ids.size()) != dims.voxel_count())
    throw Error("label map decode: " + std::to_string(ids.size()) + " ids for dims " + dims.to_string());
  for (std::uint32_t id : ids)
    if (id >= values_.size())
      throw Error("label map decode: source id " + std::to_string(id) + " out of range (" + std::to_string(values_.size()) +
                  " labels)");
  Volume out(dims, dtype_, spacing);
  visit_dtype(dtype_, [&](auto tag) {
    using T = decltype(tag);
    if constexpr (std::is_integral_v<T>) {
      auto s = out.samples<T>();
#pragma omp parallel for num_threads(thread_count()) schedule(static)
      for (std::int64_t i = 0; i < std::int64_t(ids.size()); ++i) s[std::size_t(i)] = T(values_[ids[std::size_t(i)]]);
    }
  });
  return out;
}

void require_label_dtype(const std::string& file, DType dtype) {
  if (!dtype_is_integer(dtype))
    throw Error(file + ": " + std::string(dtype_name(dtype)) +
                " samples: a label volume needs integer samples (u8, i8, u16, i16, u32 or i32); convert the "
                "segmentation to an integer type first");
}

LabelValueCollector::LabelValueCollector(DType dtype) : dtype_(dtype) {
  require_integer(dtype);
  visit_dtype(dtype_, [&](auto tag) {
    using T = decltype(tag);
    if constexpr (kPresenceTable<T>) seen_.assign(presence_range<T>(), 0);
  });
}

void LabelValueCollector::add(const Volume& slab) {
  if (slab.dtype() != dtype_)
    throw Error("label values: a slab of " + std::string(dtype_name(slab.dtype())) + " samples in a " +
                std::string(dtype_name(dtype_)) + " volume");
  visit_dtype(dtype_, [&](auto tag) {
    using T = decltype(tag);
    if constexpr (std::is_integral_v<T>) {
      if constexpr (kPresenceTable<T>) {
        mark_values<T>(slab.samples<T>(), seen_);
      } else {
        const std::vector<std::int64_t> more = distinct_values<T>(slab.samples<T>());
        std::vector<std::int64_t> merged;
        merged.reserve(values_.size() + more.size());
        std::set_union(values_.begin(), values_.end(), more.begin(), more.end(), std::back_inserter(merged));
        values_ = std::move(merged);
      }
    }
  });
}

LabelMap LabelValueCollector::finish() {
  std::vector<std::int64_t> values = std::move(values_);
  visit_dtype(dtype_, [&](auto tag) {
    using T = decltype(tag);
    if constexpr (kPresenceTable<T>) {
      constexpr std::int64_t lo = std::numeric_limits<T>::min();
      for (std::size_t v = 0; v < seen_.size(); ++v)
        if (seen_[v]) values.push_back(std::int64_t(v) + lo);
    }
  });
  return LabelMap(dtype_, std::move(values));
}

void assign_source_ids(const Volume& labels, const LabelMap& map, std::vector<std::uint32_t>& ids) {
  if (labels.dtype() != map.dtype())
    throw Error("label map: " + std::string(dtype_name(labels.dtype())) + " samples for a map of " +
                std::string(dtype_name(map.dtype())) + " labels");
  visit_dtype(labels.dtype(), [&](auto tag) {
    using T = decltype(tag);
    if constexpr (std::is_integral_v<T>) assign_ids<T>(labels.samples<T>(), map.values(), ids);
  });
}

SourceIds to_source_ids(const Volume& labels) {
  LabelValueCollector values(labels.dtype());
  values.add(labels);
  SourceIds out;
  out.dims = labels.dims();
  out.spacing = labels.spacing();
  out.map = values.finish();
  assign_source_ids(labels, out.map, out.ids);
  return out;
}

}  // namespace strata::mixture
