#include "strata/io/byte_source.hpp"

#include <algorithm>
#include <cctype>

#include "strata/io/files.hpp"
#include "strata/io/http_source.hpp"

namespace strata::io {

namespace {

// A local file: reads are views of one shared mapping, never copies.
class MappedSource final : public ByteSource {
 public:
  explicit MappedSource(const std::filesystem::path& path)
      : name_(path.string()), file_(std::make_shared<MappedFile>(path)) {}
  const std::string& name() const override { return name_; }
  std::uint64_t size() const override { return file_->size(); }
  SharedBytes read(std::uint64_t offset, std::uint64_t size) const override {
    return {file_, {file_->data() + offset, std::size_t(size)}};
  }

 private:
  std::string name_;
  std::shared_ptr<MappedFile> file_;
};

// A member of a volume set: offsets shifted into the outer file, which owns the transfers.
class SubrangeSource final : public ByteSource {
 public:
  SubrangeSource(std::shared_ptr<const ByteSource> outer, std::uint64_t offset, std::uint64_t size, std::string name)
      : outer_(std::move(outer)), offset_(offset), size_(size), name_(std::move(name)) {}
  const std::string& name() const override { return name_; }
  std::uint64_t size() const override { return size_; }
  SharedBytes read(std::uint64_t offset, std::uint64_t size) const override {
    return outer_->read(offset_ + offset, size);
  }
  void prefetch(std::span<const ByteRange> ranges) const override {
    std::vector<ByteRange> shifted(ranges.begin(), ranges.end());
    for (ByteRange& r : shifted) r.offset += offset_;
    outer_->prefetch(shifted);
  }
  bool remote() const override { return outer_->remote(); }
  TransferStats transfer_stats() const override { return outer_->transfer_stats(); }

 private:
  std::shared_ptr<const ByteSource> outer_;
  std::uint64_t offset_, size_;
  std::string name_;
};

bool starts_with_nocase(std::string_view text, std::string_view prefix) {
  return text.size() >= prefix.size() && std::equal(prefix.begin(), prefix.end(), text.begin(), [](char lower, char c) {
           return std::tolower(static_cast<unsigned char>(c)) == lower;
         });
}

}  // namespace

bool is_url(std::string_view path) {
  return starts_with_nocase(path, "http://") || starts_with_nocase(path, "https://");
}

std::shared_ptr<const ByteSource> open_byte_source(const std::filesystem::path& path) {
  if (is_url(path.string())) return shared_http_source(path.string());
  return std::make_shared<MappedSource>(path);
}

std::shared_ptr<const ByteSource> byte_subrange(std::shared_ptr<const ByteSource> outer, std::uint64_t offset,
                                                std::uint64_t size, std::string name) {
  return std::make_shared<SubrangeSource>(std::move(outer), offset, size, std::move(name));
}

}  // namespace strata::io
