#pragma once
// A Zarr store on a web server or object store (an http:// or https:// URL): each key is the URL
// root/key, fetched whole with one GET; 404 means "no such key" (a missing chunk is the fill
// value). What `strata serve` publishes under /zarr/<name>, and any static OME-Zarr on HTTP(S).
#include <memory>
#include <string>

#include "io/zarr/zarr_store.hpp"

namespace strata::io::detail {

// The store whose root is `url` (a trailing "/" is ignored).
std::shared_ptr<const ZarrStore> open_http_store(const std::string& url);

}  // namespace strata::io::detail
