#pragma once
// The built-in volume formats, each defined in its own file and registered by one line in
// format_registry.cpp.
#include "strata/io/formats.hpp"

namespace strata::io::detail {

// raw (raw.cpp): bare samples whose dims and dtype come from a JSON sidecar or ReadOptions.
VolumeFormat raw_format();
// NRRD (nrrd.cpp): attached and detached headers, raw or gzip data, 4-D files.
VolumeFormat nrrd_format();
// NIfTI-1 and NIfTI-2 single files (nifti.cpp), plain or gzip-compressed.
VolumeFormat nifti_format();
// TIFF (tiff.cpp): multi-page files and folders of slices.
VolumeFormat tiff_format();
// MRC / MRCS / REC / CCP4 map (mrc.cpp): cryo-EM and cryo-ET volumes.
VolumeFormat mrc_format();
// VTK image data: XML .vti and legacy .vtk STRUCTURED_POINTS (vtk.cpp, vtk/).
VolumeFormat vtk_format();
// Neuroglancer precomputed folders (precomputed.cpp, precomputed/): chunked multiscale volumes.
VolumeFormat precomputed_format();
// DICOM (dicom.cpp, dicom/): a folder of one series' slices or a single (multi-frame) file, read only.
VolumeFormat dicom_format();
// Zarr v2 / v3 stores and OME-Zarr images (zarr.cpp, zarr/): folders of chunked arrays.
VolumeFormat zarr_format();
// HDF5 (hdf5.cpp, hdf5/): datasets of 3 to 5 dimensions through the HDF5 C library.
VolumeFormat hdf5_format();

}  // namespace strata::io::detail
