// Every single-file NIfTI of python3-nibabel's test data (nibabel/tests/data: NIfTI-1 and -2,
// both byte orders, scaling, NaN, time series, CIFTI) read by Strata and compared with nibabel's
// own decode, volume by volume (skipped when nibabel is not installed; ./setup.sh installs it).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "io/io_test_util.hpp"
#include "strata/io/volume_io.hpp"
#include "support/test_support.hpp"

namespace strata {
namespace {

namespace fs = std::filesystem;

const fs::path kNibabelData = "/usr/lib/python3/dist-packages/nibabel/tests/data";

// nibabel's decode of every .nii/.nii.gz there: `<n>.f8` holds its samples as f64, first index
// fastest, all volumes; `index.json` lists {"file", "dims": [x, y, z], "volumes"} per n. CIFTI
// files are read as the NIfTI-2 images they are.
const char* kDecodeScript = R"(
import glob, json, os, sys, numpy, nibabel
out = sys.argv[1]
index = []
for n, f in enumerate(sorted(glob.glob(os.path.join(sys.argv[2], '*.nii')) + glob.glob(os.path.join(sys.argv[2], '*.nii.gz')))):
    image = nibabel.load(f)
    if not isinstance(image, (nibabel.Nifti1Image, nibabel.Nifti2Image)):
        image = nibabel.Nifti2Image.from_filename(f)
    a = numpy.asarray(image.dataobj, dtype=numpy.float64)
    shape = list(a.shape) + [1] * (3 - a.ndim)
    volumes = int(numpy.prod(shape[3:])) if len(shape) > 3 else 1
    a.reshape(-1, order='F').astype('<f8').tofile(os.path.join(out, '%d.f8' % n))
    index.append({'file': os.path.basename(f), 'dims': shape[:3], 'volumes': volumes})
json.dump(index, open(os.path.join(out, 'index.json'), 'w'))
)";

TEST(IoNiftiNibabelCorpus, EveryFileEqualsNibabelsDecode) {
  if (!fs::exists(kNibabelData / "example_nifti2.nii.gz")) GTEST_SKIP() << "python3-nibabel not installed";
  test::TempDir dir;
  test::io::write_bytes(dir / "decode.py", kDecodeScript, std::strlen(kDecodeScript));
  std::string out;
  ASSERT_EQ(test::run_command("/usr/bin/python3 " + test::shell_quoted(dir / "decode.py") + " " +
                                  test::shell_quoted(dir.path()) + " " + test::shell_quoted(kNibabelData),
                              &out),
            0)
      << out;
  const auto index = nlohmann::json::parse(test::io::read_text(dir / "index.json"));
  ASSERT_GE(index.size(), 8u);
  std::int64_t compared = 0;
  for (std::size_t n = 0; n < index.size(); ++n) {
    const auto& entry = index[n];
    const fs::path file = kNibabelData / entry["file"].get<std::string>();
    SCOPED_TRACE(file.filename().string());
    const Extent dims{entry["dims"][0].get<std::int64_t>(), entry["dims"][1].get<std::int64_t>(),
                      entry["dims"][2].get<std::int64_t>()};
    const auto volumes = entry["volumes"].get<std::int64_t>();
    const auto expected_bytes = test::io::read_bytes(dir / (std::to_string(n) + ".f8"));
    std::vector<double> expected(expected_bytes.size() / 8);
    std::memcpy(expected.data(), expected_bytes.data(), expected.size() * 8);
    const auto per_volume = std::size_t(dims.x * dims.y * dims.z);
    ASSERT_EQ(expected.size(), per_volume * std::size_t(volumes));
    for (std::int64_t t = 0; t < volumes; ++t) {
      io::ReadOptions options;
      options.volume = t;
      const Volume v = io::read_volume(file, options).converted(DType::f64);
      ASSERT_EQ(v.dims(), dims);
      const auto got = v.samples<double>();
      for (std::size_t i = 0; i < per_volume; ++i) {
        const double want = expected[std::size_t(t) * per_volume + i];
        if (std::isnan(want)) {
          EXPECT_TRUE(std::isnan(got[i])) << "volume " << t << " voxel " << i;
          continue;
        }
        // Scaled values come back as f32: within its rounding of nibabel's f64.
        ASSERT_LE(std::abs(got[i] - want), 6e-8 * std::max(1.0, std::abs(want))) << "volume " << t << " voxel " << i;
      }
      ++compared;
    }
  }
  EXPECT_GE(compared, 8 + 1 + 19 + 1 + 99);  // the time series and the CIFTI matrix add volumes
}

}  // namespace
}  // namespace strata
