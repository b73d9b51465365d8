// Seed inputs for the payload and section targets, cut out of real .strata files:
//   fuzz_extract_seeds OUT_CORPUS_DIR FILE.strata...
// writes OUT/tucker_fixed/<file>-<n>, OUT/tucker_coded/<file>-<n>, OUT/masked/<file>-<n> (each with the target's
// prefix bytes, at most 3 per file and kind), OUT/mixture_graph/<file> and
// OUT/label_ids/<file>-L<n> (the sections of label files, zstd-inflated). fuzz/make_corpus.sh
// runs it.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "strata/quant/scheme.hpp"
#include "strata/store/container.hpp"
#include "strata/store/zstd_frame.hpp"

namespace fs = std::filesystem;

namespace {

void write(const fs::path& path, const std::vector<std::byte>& prefix, std::span<const std::byte> bytes) {
  fs::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(prefix.data()), std::streamsize(prefix.size()));
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

// Index of `quant` in fuzz_tucker_fixed.cpp's kSchemes.
int scheme_index(const std::string& quant) {
  const char* names[] = {"u16,b8log+", "u16,b8log", "u8,b8lin", "u16,b16lin", "u16,b12log+",
                         "u16,b8mu+", "u16,b8mu1000+", "f32", "u8,b8mu", "f32,b16log"};
  for (int i = 0; i < 10; ++i)
    if (quant == names[i]) return i;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s OUT_CORPUS_DIR FILE.strata...\n", argv[0]);
    return 2;
  }
  const fs::path out = argv[1];
  for (int a = 2; a < argc; ++a) {
    const fs::path file = argv[a];
    const std::string stem = file.stem().string();
    const strata::store::ContainerReader reader(file);
    const auto& m = reader.metadata();
    std::map<strata::store::PayloadKind, int> written;
    for (const auto& e : reader.bricks()) {
      int& n = written[e.kind];
      if (n >= 3) continue;
      const auto payload = reader.payload(e);
      const auto width = std::byte(m.value("brick", 8));
      const auto rank = std::byte(m.value("rank", 4));
      if (e.kind == strata::store::PayloadKind::tucker || e.kind == strata::store::PayloadKind::tucker_zstd) {
        const std::byte zstd{e.kind == strata::store::PayloadKind::tucker_zstd};
        const auto scheme = std::byte(scheme_index(m.value("quant", std::string())));
        write(out / "tucker_fixed" / (stem + "-" + std::to_string(n++)), {zstd, scheme, rank, width}, payload);
      } else if (e.kind == strata::store::PayloadKind::tucker_coded) {
        write(out / "tucker_coded" / (stem + "-" + std::to_string(n++)), {rank}, payload);
      } else if (e.kind == strata::store::PayloadKind::masked) {
        write(out / "masked" / (stem + "-" + std::to_string(n++)), {rank, width}, payload);
      }
    }
    if (reader.has_section("mixture_graph")) {
      const auto graph = reader.section("mixture_graph");
      write(out / "mixture_graph" / stem, {}, graph);
    }
    const bool fixed = m.value("ids", std::string()) == "fixed";
    const bool zstd = m.value("ids_compression", std::string("none")) == "zstd";
    for (int l = 0; reader.has_section("ids_L" + std::to_string(l)); ++l) {
      const std::string name = "ids_L" + std::to_string(l);
      std::vector<std::byte> bytes;
      const auto section = reader.section(name);
      if (zstd) strata::store::zstd_decompress(section, 1u << 26, bytes, file.string(), name);
      else bytes.assign(section.begin(), section.end());
      write(out / "label_ids" / (stem + "-L" + std::to_string(l)), {std::byte(fixed ? 1 : 0)}, bytes);
    }
  }
  return 0;
}
