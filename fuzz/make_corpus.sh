#!/usr/bin/env bash
# Makes the seed corpora of fuzz/corpus again (and fuzz/data, the server target's datasets) from
# tiny volumes: strata generate/convert/compress/labels encode (build/release/strata) and
# fuzz_extract_seeds (build/fuzz) for the payload and section targets. The transfer-function,
# colour-map, server and precomputed seeds are written by hand and kept (precomputed: the first
# byte picks the part fuzzed, see fuzz/fuzz_precomputed.cpp).
#   fuzz/make_corpus.sh
set -euo pipefail
cd "$(dirname "$0")/.."
strata="build/release/strata --progress none"
cmake --build build/release --target strata >/dev/null
cmake --build build/fuzz --target fuzz_extract_seeds >/dev/null
w=$(mktemp -d)
trap 'rm -rf "$w"' EXIT
$strata generate prisms --size 10,9,8 -o "$w/prisms.nrrd"
$strata generate voronoi --size 10,9,8 --count 6 -o "$w/cells.nrrd"
$strata generate sphere --size 6 --dtype f32 -o "$w/sphere.nrrd"
$strata convert "$w/prisms.nrrd" "$w/prisms_raw.nrrd" --uncompressed
# A dimension beyond NIfTI-1's 16-bit dim: the writer makes it NIfTI-2.
$strata generate sphere --size 32768,1,1 --dtype u8 -o "$w/wide_nifti2.nii.gz"
for f in prisms.nii prisms.nii.gz cells.nii prisms.tif cells.tif sphere.tif prisms.raw sphere.raw; do
  src=${f%%.*}.nrrd
  $strata convert "$w/$src" "$w/$f"
done
$strata compress "$w/prisms.nrrd" -o "$w/scalar.strata" --brick 8 --overlap 1 --rank 4
$strata compress "$w/prisms.nrrd" -o "$w/scalar_nozstd.strata" --brick 8 --overlap 1 --rank 4 --zstd 0 --quant u8,b8lin
$strata compress "$w/prisms.nrrd" -o "$w/coded.strata" --brick 8 --overlap 1 --psnr 40
$strata compress "$w/prisms.nrrd" -o "$w/coded_max.strata" --brick 8 --overlap 1 --max-error 0.5
$strata compress fuzz/corpus/nrrd/nan_f32.nrrd -o "$w/masked.strata" --brick 8 --overlap 1 --psnr 40
$strata compress fuzz/corpus/nrrd/nan_f32.nrrd -o "$w/masked_rank.strata" --brick 8 --overlap 1 --rank 4
$strata labels encode "$w/cells.nrrd" -o "$w/labels.strata"
# A volume set: two time points (prisms, then prisms again) of a 4-D NRRD, one member each.
{ printf 'NRRD0004\ntype: uint16\ndimension: 4\nsizes: 10 9 8 2\nkinds: domain domain domain list\nendian: little\nencoding: raw\n\n'
  cat "$w/prisms.raw" "$w/prisms.raw"; } >"$w/series.nrrd"
$strata compress "$w/prisms.nrrd" -o "$w/global.strata" --brick 8 --overlap 1 --rank 4 --codec ta-global
$strata compress "$w/series.nrrd" -o "$w/volume_set.strata" --brick 8 --overlap 1 --psnr 40 --all-volumes
$strata labels encode "$w/cells.nrrd" -o "$w/labels_fixed.strata" --ids fixed
$strata labels encode "$w/cells.nrrd" -o "$w/labels_normals.strata" --normals

c=fuzz/corpus
mkdir -p $c/{nrrd,nifti,tiff,raw_sidecar,container} fuzz/data
cp "$w/prisms.nrrd" $c/nrrd/prisms_gzip.nrrd
cp "$w/prisms_raw.nrrd" $c/nrrd/prisms_raw.nrrd
cp "$w/cells.nrrd" $c/nrrd/cells.nrrd
cp "$w/sphere.nrrd" $c/nrrd/sphere_f32.nrrd
cp tests/data/fibsem_medulla_sp_crop20.nrrd $c/nrrd/  # nan_f32.nrrd is kept: written by hand
cp "$w/prisms.nii" "$w/prisms.nii.gz" "$w/cells.nii" "$w/wide_nifti2.nii.gz" $c/nifti/
cp "$w/prisms.tif" "$w/cells.tif" "$w/sphere.tif" $c/tiff/
# VTK: zlib and raw appended .vti and legacy BINARY .vtk; the ascii, base64 and legacy ASCII seeds
# are written by hand and kept.
mkdir -p $c/vtk
$strata convert "$w/prisms.nrrd" $c/vtk/prisms_zlib.vti
$strata convert "$w/prisms.nrrd" $c/vtk/prisms_raw.vti --uncompressed
$strata convert "$w/prisms.nrrd" $c/vtk/prisms_legacy.vtk
for f in prisms sphere; do (cat "$w/$f.raw.json"; printf '\n--\n'; cat "$w/$f.raw") >$c/raw_sidecar/$f; done
cp "$w"/{scalar,scalar_nozstd,coded,coded_max,labels,labels_fixed,labels_normals,volume_set,global}.strata $c/container/
build/fuzz/fuzz/fuzz_extract_seeds $c "$w"/{scalar,scalar_nozstd,coded,coded_max,masked,masked_rank,labels,labels_fixed}.strata
cp "$w/scalar.strata" fuzz/data/scalar.strata
cp "$w/labels.strata" fuzz/data/labels.strata
cp "$w/sphere.nrrd" fuzz/data/plain.nrrd
