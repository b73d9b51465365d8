// Zarr stores on a web server (tests/support/range_server.py): an OME-Zarr image written here
// reads back over HTTP equal to the local copy with its geometry, found by asking the server when
// the URL has no extension; retries cover a flaky server; a chunk the server does not have is
// the fill value; a missing image, a group that cannot be listed and a .strata URL are refused
// naming the URL.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>

#include "io/io_test_util.hpp"
#include "strata/io/formats.hpp"
#include "strata/io/volume_io.hpp"
#include "support/range_server.hpp"
#include "support/test_support.hpp"

namespace strata::io {
namespace {

namespace fs = std::filesystem;
using test::error_of;
using test::RangeServer;
using test::TempDir;

// Two chunks along x (the writer's chunks are 64³), so one can go missing.
const Extent kDims{70, 12, 9};

class IoZarrHttp : public ::testing::Test {
 protected:
  IoZarrHttp() {
    ::setenv("STRATA_HTTP_BACKOFF_MS", "5", 1);  // the flaky server: retries without long waits
    volume_ = test::io::random_volume(kDims, DType::u16, 7, {0.5, 1.25, 2.0});
    Geometry geometry = volume_.info().geometry;
    geometry.origin = {10.0, -4.0, 3.5};
    volume_.set_geometry(geometry);
    write_volume(dir_ / "img.ome.zarr", volume_);
    WriteOptions as_zarr;
    as_zarr.format = "zarr";
    write_volume(dir_ / "noext", volume_, as_zarr);
  }
  ~IoZarrHttp() override { ::unsetenv("STRATA_HTTP_BACKOFF_MS"); }

  TempDir dir_;
  Volume volume_;
  RangeServer server_{dir_.path()};
};

TEST_F(IoZarrHttp, AnImageReadsBackEqualWithItsGeometry) {
  for (const char* name : {"img.ome.zarr", "noext", "img.ome.zarr/"}) {
    SCOPED_TRACE(name);
    const std::string url = server_.url("ok", name);
    EXPECT_EQ(detect_format(url).name, "zarr");
    EXPECT_TRUE(is_remote_volume(url));
    const auto source = open_volume(url);
    EXPECT_EQ(source->info().dims, kDims);
    EXPECT_EQ(source->info().spacing, volume_.info().spacing);
    EXPECT_EQ(source->info().geometry.origin, volume_.info().geometry.origin);
    const Volume read = source->read_all();
    ASSERT_EQ(read.byte_size(), volume_.byte_size());
    EXPECT_EQ(std::memcmp(read.bytes(), volume_.bytes(), read.byte_size()), 0);
  }
}

TEST_F(IoZarrHttp, AFlakyServerIsRetried) {
  const Volume read = open_volume(server_.url("flaky", "img.ome.zarr"))->read_all();
  EXPECT_EQ(std::memcmp(read.bytes(), volume_.bytes(), read.byte_size()), 0);
}

TEST_F(IoZarrHttp, AChunkTheServerDoesNotHaveIsTheFillValue) {
  const fs::path second_chunk = dir_ / "img.ome.zarr" / "0" / "0" / "0" / "1";
  ASSERT_TRUE(fs::is_regular_file(second_chunk));
  fs::remove(second_chunk);
  const Volume read = open_volume(server_.url("ok", "img.ome.zarr"))->read_all();
  const auto got = read.samples<std::uint16_t>();
  const auto want = volume_.samples<std::uint16_t>();
  for (std::int64_t z = 0; z < kDims.z; ++z)
    for (std::int64_t y = 0; y < kDims.y; ++y)
      for (std::int64_t x = 0; x < kDims.x; ++x) {
        const std::size_t i = std::size_t((z * kDims.y + y) * kDims.x + x);
        ASSERT_EQ(got[i], x < 64 ? want[i] : 0) << x << "," << y << "," << z;
      }
}

TEST_F(IoZarrHttp, RefusalsNameTheUrl) {
  const std::string missing = server_.url("ok", "gone.ome.zarr");
  EXPECT_NE(error_of([&] { open_volume(missing); }).find(missing), std::string::npos);

  const std::string unknown = server_.url("ok", "nothing-here");
  const std::string why = error_of([&] { detect_format(unknown); });
  EXPECT_NE(why.find(unknown), std::string::npos) << why;
  EXPECT_NE(why.find("not a volume that can be read from a web server"), std::string::npos) << why;

  const std::string strata_url = server_.url("ok", "x.strata");
  EXPECT_FALSE(is_remote_volume(strata_url));
  EXPECT_NE(error_of([&] { detect_format(strata_url); }).find(strata_url), std::string::npos);

  // A group without multiscales cannot be listed over HTTP: the message says to name the array.
  fs::remove(dir_ / "img.ome.zarr" / ".zattrs");
  const std::string group = server_.url("ok", "img.ome.zarr");
  const std::string unlisted = error_of([&] { open_volume(group); });
  EXPECT_NE(unlisted.find("--dataset"), std::string::npos) << unlisted;
  ReadOptions level0;
  level0.dataset = "0";
  EXPECT_EQ(open_volume(group, level0)->info().dims, kDims);
}

}  // namespace
}  // namespace strata::io
