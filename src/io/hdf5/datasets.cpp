#include "io/hdf5/datasets.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "io/hdf5/library.hpp"
#include "strata/core/error.hpp"

namespace strata::io::detail::hdf5 {

namespace {

// Listed in a message at most; the rest are counted.
constexpr std::size_t kListedInMessage = 40;
// Datasets looked at when searching for the only volume.
constexpr std::size_t kSearchLimit = 10000;

struct Visit {
  std::vector<DatasetEntry> entries;
  std::size_t limit;
};

DatasetEntry describe(hid_t dataset, std::string path) {
  DatasetEntry entry{.path = std::move(path)};
  const Handle type(H5Dget_type(dataset), H5Tclose);
  const Handle space(H5Dget_space(dataset), H5Sclose);
  if (!type.valid() || !space.valid()) {
    H5Eclear2(H5E_DEFAULT);
    entry.type = "unreadable";
    return entry;
  }
  entry.type = type_text(type.get());
  const int rank = H5Sget_simple_extent_ndims(space.get());
  std::vector<hsize_t> dims(std::size_t(std::max(rank, 0)));
  if (rank > 0) H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
  entry.shape = "(";
  for (std::size_t i = 0; i < dims.size(); ++i) entry.shape += fmt::format("{}{}", i ? ", " : "", dims[i]);
  entry.shape += dims.size() == 1 ? ",)" : ")";
  entry.is_volume = rank >= 3 && rank <= 5 && sample_type(type.get()).has_value();
  return entry;
}

// H5Lvisit's callback; the link-info type differs between library versions and is deduced.
template <class LinkInfo>
herr_t visit_link(hid_t group, const char* name, const LinkInfo* info, void* data) {
  auto& visit = *static_cast<Visit*>(data);
  if (info->type != H5L_TYPE_HARD) return 0;  // soft and external links would list a dataset twice or leave the file
  const hid_t object = H5Oopen(group, name, H5P_DEFAULT);
  if (object < 0) {
    H5Eclear2(H5E_DEFAULT);
    return 0;
  }
  const Handle handle(object, H5Oclose);
  if (H5Iget_type(object) == H5I_DATASET) visit.entries.push_back(describe(object, std::string("/") + name));
  return visit.entries.size() >= visit.limit ? 1 : 0;
}

}  // namespace

std::vector<DatasetEntry> list_datasets(hid_t file, std::size_t limit) {
  Visit visit{.entries = {}, .limit = limit};
  if (H5Lvisit(file, H5_INDEX_NAME, H5_ITER_INC, visit_link, &visit) < 0) H5Eclear2(H5E_DEFAULT);
  return visit.entries;
}

std::string datasets_text(const std::vector<DatasetEntry>& entries) {
  std::vector<const DatasetEntry*> order;
  for (const DatasetEntry& e : entries) order.push_back(&e);
  std::stable_partition(order.begin(), order.end(), [](const DatasetEntry* e) { return e->is_volume; });
  std::string text;
  for (std::size_t i = 0; i < order.size() && i < kListedInMessage; ++i)
    text += fmt::format("{}{} {} {}", i ? ", " : "", order[i]->path, order[i]->shape, order[i]->type);
  if (order.size() > kListedInMessage) text += fmt::format(" and {} more", order.size() - kListedInMessage);
  return text.empty() ? "none" : text;
}

std::string only_volume_dataset(hid_t file, const std::string& file_name) {
  const std::vector<DatasetEntry> entries = list_datasets(file, kSearchLimit);
  const auto volumes = std::count_if(entries.begin(), entries.end(), [](const DatasetEntry& e) { return e.is_volume; });
  if (volumes == 1)
    return std::find_if(entries.begin(), entries.end(), [](const DatasetEntry& e) { return e.is_volume; })->path;
  if (volumes == 0)
    throw FormatError(file_name, "dataset",
                      fmt::format("no numeric dataset of 3 to 5 dimensions; the file holds: {}", datasets_text(entries)));
  throw FormatError(file_name, "dataset",
                    fmt::format("{} datasets could be the volume; name one as file.h5:/path or with --dataset: {}",
                                volumes, datasets_text(entries)));
}

}  // namespace strata::io::detail::hdf5
