#pragma once
// A Zarr store in a zip file (zarr-python's ZipStore, `zip -r x.zarr.zip x.zarr`): the central
// directory is read once when the store opens, members are read by offset from a memory map.
#include <filesystem>
#include <memory>

#include "io/zarr/zarr_store.hpp"

namespace strata::io::detail {

// FormatError(path, field, ...) when the file is not a zip or its directory is damaged.
std::shared_ptr<const ZarrStore> open_zip_store(const std::filesystem::path& path);

}  // namespace strata::io::detail
