// The server's HTTP/1.1 request reader (src/server/http_wire.hpp) on raw connection bytes: what
// a client sends, pipelined requests included. Input: the bytes as they arrive.
//
// Contract beyond "no crash": the bytes fed at once and fed in pieces (cut where the input's own
// bytes say) give the same requests and the same refusal; no request exceeds the limits; and
// each answer written for a request is a well-formed head.
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

#include "server/http_wire.hpp"
#include "support.hpp"

namespace {

using strata::server::wire::RequestReader;

struct Outcome {
  std::vector<std::string> requests;  // method, path, parameters, body, framing, one string each
  int error = 0;
};

std::string describe(const strata::server::wire::Request& r) {
  std::string s = r.request.method + ' ' + r.request.path + ' ';
  for (const auto& [key, value] : r.request.params) s += key + '=' + value + '&';
  s += ' ' + std::to_string(r.request.body.size()) + ':' + r.request.body;
  s += r.keep_alive ? " keep" : " close";
  s += r.head ? " head" : "";
  s += r.accepts_gzip ? " gzip" : "";
  return s;
}

strata::server::wire::Limits limits() {
  strata::server::wire::Limits l;
  l.max_head_bytes = 2048;  // small, so the fuzzer reaches them
  l.max_headers = 16;
  l.max_body_bytes = 4096;
  return l;
}

// Feeds `pieces` one after another, taking every complete request.
Outcome read_all(const std::vector<std::string_view>& pieces) {
  Outcome o;
  RequestReader reader(limits());
  for (std::string_view piece : pieces) {
    reader.feed(piece);
    while (true) {
      const auto status = reader.advance();
      (void)reader.take_continue();
      if (status == RequestReader::Status::failed) {
        o.error = reader.error_status();
        return o;
      }
      if (status != RequestReader::Status::complete) break;
      const auto request = reader.take();
      if (request.request.body.size() > limits().max_body_bytes) std::abort();
      strata::server::HttpResponse answer;
      answer.body = request.request.path;
      answer.set_header("X-Echo", request.request.method);
      const std::string bytes = strata::server::wire::write_response(
          answer, {.keep_alive = request.keep_alive, .head = request.head, .accepts_gzip = request.accepts_gzip});
      if (!bytes.starts_with("HTTP/1.1 200 OK\r\n") || bytes.find("\r\n\r\n") == std::string::npos) std::abort();
      o.requests.push_back(describe(request));
    }
  }
  return o;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const Outcome whole = read_all({text});
  // Pieces of 1 to 8 bytes, the lengths taken from the input's bytes in turn.
  std::vector<std::string_view> pieces;
  for (std::size_t at = 0, i = 0; at < text.size(); ++i) {
    const std::size_t n = std::min<std::size_t>(text.size() - at, 1 + std::uint8_t(text[i % text.size()]) % 8);
    pieces.push_back(text.substr(at, n));
    at += n;
  }
  const Outcome split = read_all(pieces);
  if (whole.requests != split.requests || whole.error != split.error) std::abort();
  return 0;
}
