#pragma once
// Where a Zarr store's keys live: a folder (one file per key) or a zip file (one member per key,
// src/io/zarr/zip_store.cpp). The reader asks only "how large is this key" and "the bytes of
// this range of it", so both kinds share every line above this interface. Keys are zarr's:
// "/"-separated, relative to the store's root ("0/.zarray", "c/0/1/2"); "" is the root node.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace strata::io::detail {

class ZarrStore {
 public:
  virtual ~ZarrStore() = default;
  // The size of the value stored under `key`, or nothing when there is none.
  virtual std::optional<std::uint64_t> size(const std::string& key) const = 0;
  // Bytes [offset, offset + length) of `key`'s value. FormatError(name(key), field, ...) when the
  // range is not inside it or it cannot be read.
  virtual std::vector<std::byte> read(const std::string& key, std::uint64_t offset, std::uint64_t length,
                                      const std::string& field) const = 0;
  // The names of the nodes directly below `prefix` (a key, "" for the root), sorted.
  virtual std::vector<std::string> children(const std::string& prefix) const = 0;
  // How messages name `key` (a file path, "store.zarr.zip:/key", or a URL).
  virtual std::string name(const std::string& key) const = 0;
  // Whether children() lists the store (not over HTTP, which has no listing).
  virtual bool listable() const { return true; }

  bool exists(const std::string& key) const { return size(key).has_value(); }
};

// "a/b" + "c" -> "a/b/c"; "" + "c" -> "c".
std::string join_key(const std::string& prefix, const std::string& name);

// The store at `path`: an http(s) URL, a folder, or a zip file for any other regular file.
std::shared_ptr<const ZarrStore> open_zarr_store(const std::filesystem::path& path);

// Whether `path` names a zip store by its extension (.zip: .zarr.zip, .ome.zarr.zip).
bool is_zip_store_name(const std::filesystem::path& path);

}  // namespace strata::io::detail
