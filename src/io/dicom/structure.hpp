#pragma once
// A walk over a Part 10 file's element headers before GDCM parses it. Debian builds GDCM with
// its assertions on: its parser aborts the process on a file that ends inside an element, or
// holds no data set after the file meta group. This walk refuses such files with a FormatError.
#include <filesystem>

namespace strata::io::detail::dicom {

/// @brief Checks that `file` starts with the Part 10 signature, that its meta group and data set
/// are a chain of element headers (explicit VR, or implicit VR when TransferSyntaxUID says so)
/// whose values lie inside the file, up to the pixel data, and that the data set is not empty.
/// Throws FormatError(file, tag, ...) naming the first element that is not.
void check_element_structure(const std::filesystem::path& file);

}  // namespace strata::io::detail::dicom
