#pragma once
/// @file
/// @brief The files and folders a volume path stands for when it is read (a detached NRRD
/// header and its data files, a raw file and its JSON sidecar, a folder of slices) and when it
/// is written (the output, the data file or sidecar its writer adds, the `<name>.tmp` each is
/// written as), and the one check that an output spares every input: compared by identity
/// (device and inode), so another spelling, a symlink or a hard link of an input is that input,
/// and by folders, so an output inside an input folder, or an input inside an output folder the
/// writer replaces whole, is refused too. Each format says what it reads and writes beside the
/// path (VolumeFormat::files_read, VolumeFormat::files_written in formats.hpp).
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace strata::io {

struct WriteOptions;

/// @brief A file or folder that reading or writing a path touches.
struct TouchedPath {
  std::filesystem::path path;
  /// The path the caller named (the input or the output) that touches `path`.
  std::filesystem::path named;
  /// What `path` is to `named`: empty for `named` itself, else a noun ("data file", "JSON
  /// sidecar", "temporary file", "staging folder").
  std::string role;
  /// The header field that names `path`, when one does ("data file").
  std::string field;
  /// An output folder its writer replaces whole: whatever lies inside it is lost.
  bool replaced_folder = false;
};

/// @brief `path` touched as itself (`named` = `path`, no role).
TouchedPath touched_itself(const std::filesystem::path& path, bool replaced_folder = false);

/// @brief What reading the volume at `path` touches: the path itself (for `file.h5:/dataset`
/// the container file; a folder counts with everything inside it) and what its format reads
/// beside it (VolumeFormat::files_read). A path of no known format, or whose format cannot say
/// (an unreadable header), is only itself: its reader refuses it before anything is written.
std::vector<TouchedPath> files_read(const std::filesystem::path& path);

/// @brief What writing a volume to `path` (with `options`) creates or replaces: the output (for
/// `out.h5:/group/name` the container file), its `<name>.tmp`, and what its format writes
/// beside it (VolumeFormat::files_written). A path of no known format is a plain file.
std::vector<TouchedPath> files_written(const std::filesystem::path& path, const WriteOptions& options);

/// @brief A file that is not a volume (a .strata container, an image, a JSON report) written as
/// `<name>.tmp` and renamed: the file and its temporary.
std::vector<TouchedPath> plain_file_written(const std::filesystem::path& path);

/// @brief Why writing `outputs` would destroy or change one of `inputs`, as a sentence naming
/// both paths (and the role and field that tie each to what the caller named); nullopt when it
/// would not. An output conflicts with an input when both exist and are the same file or folder
/// (or have the same absolute path), when it lies inside an input folder, or when it is a
/// replaced folder and an input lies inside it.
std::optional<std::string> overwrite_conflict(const std::vector<TouchedPath>& outputs,
                                              const std::vector<TouchedPath>& inputs);

}  // namespace strata::io
