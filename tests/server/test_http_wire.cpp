// HTTP/1.1 on the wire without sockets (src/server/http_wire.hpp): requests cut out of a
// connection's bytes however they arrive, pipelined ones in order, chunked bodies, the framing
// that is refused and with which status, the limits, and the bytes of a response.
#include <gtest/gtest.h>

#include <zlib.h>

#include <string>
#include <vector>

#include "server/http_wire.hpp"

namespace strata::server::wire {
namespace {

using Status = RequestReader::Status;

// Every request the bytes hold, fed `piece` bytes at a time; the error status (0: none) last.
struct Read {
  std::vector<Request> requests;
  int error = 0;
  std::string message;
  bool pending = false;  // bytes of an unfinished request left
};

Read read(const std::string& bytes, std::size_t piece = 1 << 20, Limits limits = {}) {
  Read out;
  RequestReader reader(limits);
  for (std::size_t at = 0; at < bytes.size(); at += piece) {
    reader.feed(std::string_view(bytes).substr(at, piece));
    for (Status s = reader.advance(); s != Status::incomplete; s = reader.advance()) {
      if (s == Status::failed) {
        out.error = reader.error_status();
        out.message = reader.error_message();
        return out;
      }
      out.requests.push_back(reader.take());
    }
  }
  out.pending = reader.buffered() > 0;
  return out;
}

int status_of(const std::string& bytes) { return read(bytes).error; }

TEST(ServerHttpWire, ARequestIsCutOutHoweverItsBytesArrive) {
  const std::string wire =
      "POST /api/datasets/1/palette?a=1&b=%20x+y HTTP/1.1\r\nHost: h\r\nContent-Length: 5\r\n"
      "Accept-Encoding: gzip, br\r\n\r\nhello";
  for (std::size_t piece : {std::size_t(1), std::size_t(2), std::size_t(3), std::size_t(7), wire.size()}) {
    const Read r = read(wire, piece);
    ASSERT_EQ(r.requests.size(), 1u) << "pieces of " << piece;
    const Request& q = r.requests[0];
    EXPECT_EQ(q.request.method, "POST");
    EXPECT_EQ(q.request.path, "/api/datasets/1/palette");
    EXPECT_EQ(q.request.params.find("b")->second, " x y");
    EXPECT_EQ(q.request.body, "hello");
    EXPECT_TRUE(q.keep_alive);
    EXPECT_TRUE(q.accepts_gzip);
    EXPECT_FALSE(q.head);
    EXPECT_FALSE(r.pending);
  }
}

TEST(ServerHttpWire, PipelinedRequestsComeOutInOrder) {
  std::string wire;
  for (int i = 0; i < 5; ++i) wire += "GET /" + std::to_string(i) + " HTTP/1.1\r\n\r\n";
  wire += "POST /p HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n3\r\nabc\r\n2;ext=1\r\nde\r\n0\r\nX-Trailer: 1\r\n\r\n";
  wire += "\r\nHEAD /last HTTP/1.0\n\n";  // a stray empty line, bare LF line ends
  const Read r = read(wire, 5);
  ASSERT_EQ(r.requests.size(), 7u);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(r.requests[std::size_t(i)].request.path, "/" + std::to_string(i));
  EXPECT_EQ(r.requests[5].request.body, "abcde");
  EXPECT_TRUE(r.requests[6].head);
  EXPECT_FALSE(r.requests[6].keep_alive) << "HTTP/1.0 closes unless it asks for keep-alive";
  EXPECT_FALSE(r.pending);
}

TEST(ServerHttpWire, TargetsAndConnectionOptions) {
  const Read r = read(
      "GET http://example.org:8080/api/datasets?x=1 HTTP/1.1\r\nConnection: close\r\n\r\n"
      "GET https://example.org HTTP/1.1\r\n\r\n"
      "OPTIONS * HTTP/1.1\r\n\r\n"
      "GET /a HTTP/1.0\r\nConnection: Keep-Alive\r\n\r\n"
      "GET /%2e%2e/x HTTP/1.1\r\nAccept-Encoding: gzip;q=0, identity\r\n\r\n");
  ASSERT_EQ(r.requests.size(), 5u) << r.message;
  EXPECT_EQ(r.requests[0].request.path, "/api/datasets");
  EXPECT_EQ(r.requests[0].request.params.find("x")->second, "1");
  EXPECT_FALSE(r.requests[0].keep_alive);
  EXPECT_EQ(r.requests[1].request.path, "/");
  EXPECT_EQ(r.requests[2].request.path, "*");
  EXPECT_TRUE(r.requests[3].keep_alive);
  EXPECT_EQ(r.requests[4].request.path, "/../x") << "decoded for the router, which refuses it";
  EXPECT_FALSE(r.requests[4].accepts_gzip);
}

TEST(ServerHttpWire, AmbiguousFramingIs400) {
  const std::string post = "POST /p HTTP/1.1\r\n";
  for (const char* headers : {
           "Content-Length: 3\r\nContent-Length: 4\r\n",  // conflicting values
           "Content-Length: 3, 4\r\n",
           "Content-Length: -3\r\n",
           "Content-Length: 3x\r\n",
           "Content-Length:\r\n",
           "Content-Length: 1234567890123456789\r\n",       // beyond 18 digits' worth
           "Content-Length: 3\r\nTransfer-Encoding: chunked\r\n",
           "Transfer-Encoding: chunked\r\nContent-Length: 3\r\n",
           "Content-Length : 3\r\n",                         // a space before the colon
           " Content-Length: 3\r\n",                         // a folded line
           "X: 1\r\n continued\r\n",
           "Host: a\r\nHost: b\r\n",
           "X: a\x01" "b\r\n",
           "NoColon\r\n",
       })
    EXPECT_EQ(status_of(post + headers + "\r\nabc"), 400) << headers;
  EXPECT_EQ(read(post + "Content-Length: 3\r\nContent-Length: 3, 3\r\n\r\nabc").requests.size(), 1u)
      << "the same length repeated is one length";
  EXPECT_EQ(status_of("POST /p HTTP/1.0\r\nTransfer-Encoding: chunked\r\n\r\n0\r\n\r\n"), 400);
  EXPECT_EQ(status_of(post + "Transfer-Encoding: gzip, chunked\r\n\r\n"), 501);
  EXPECT_EQ(status_of(post + "Expect: something\r\n\r\n"), 417);
  for (const char* line : {"GET /p HTTP/2.0", "GET /p HTTP/1.2", "GET /p HTTP/9.9"})
    EXPECT_EQ(status_of(line + std::string("\r\n\r\n")), 505) << line;
  for (const char* line : {"GET /p", "GET  /p HTTP/1.1", "GET /p HTTP/1.1 ", "G(T /p HTTP/1.1", "GET p HTTP/1.1",
                                  "GET /p\x7f HTTP/1.1", "GET * HTTP/1.1", "GET /p HTTP/1.x", "GET /p http/1.1"})
    EXPECT_EQ(status_of(line + std::string("\r\n\r\n")), 400) << line;
}

TEST(ServerHttpWire, MalformedChunksAre400) {
  const std::string post = "POST /p HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n";
  for (const std::string& body : std::vector<std::string>{"x\r\n", "3\r\nabcd\r\n0\r\n\r\n", "-1\r\n", "3 x\r\nabc\r\n",
                                                         "1234567890abcdef0\r\n", std::string(2000, '1') + "\r\n"})
    EXPECT_EQ(status_of(post + body), 400) << body.substr(0, 40);
}

TEST(ServerHttpWire, LimitsGiveTheirStatus) {
  Limits limits;
  limits.max_head_bytes = 1024;
  limits.max_headers = 10;
  limits.max_body_bytes = 100;
  EXPECT_EQ(read("GET /" + std::string(2000, 'a') + " HTTP/1.1\r\n\r\n", 64, limits).error, 414);
  EXPECT_EQ(read("GET / HTTP/1.1\r\nX: " + std::string(2000, 'a') + "\r\n\r\n", 64, limits).error, 431);
  std::string many = "GET / HTTP/1.1\r\n";
  for (int i = 0; i < 11; ++i) many += "X-" + std::to_string(i) + ": 1\r\n";
  EXPECT_EQ(read(many + "\r\n", 64, limits).error, 431);
  const Read big = read("POST / HTTP/1.1\r\nContent-Length: 101\r\n\r\n", 64, limits);
  EXPECT_EQ(big.error, 413) << "refused at the head, before the body is sent";
  EXPECT_EQ(read("POST / HTTP/1.1\r\nContent-Length: 100\r\n\r\n" + std::string(100, 'b'), 64, limits).requests.size(), 1u);
  std::string chunks = "POST / HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n";
  for (int i = 0; i < 11; ++i) chunks += "a\r\n0123456789\r\n";
  EXPECT_EQ(read(chunks + "0\r\n\r\n", 64, limits).error, 413);
  std::string framing = "POST / HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n";
  for (int i = 0; i < 100; ++i) framing += "1;" + std::string(500, 'e') + "\r\nx\r\n";
  EXPECT_EQ(read(framing, 4096, limits).error, 413) << "chunk extensions cost as much as a body";
  EXPECT_EQ(read(std::string(100, '\n') + "GET / HTTP/1.1\r\n\r\n").error, 400) << "a few empty lines, not endless";
}

TEST(ServerHttpWire, ContinueIsAskedOncePerRequest) {
  RequestReader reader;
  reader.feed("POST /p HTTP/1.1\r\nExpect: 100-continue\r\nContent-Length: 3\r\n\r\n");
  EXPECT_EQ(reader.advance(), Status::incomplete);
  EXPECT_EQ(reader.phase(), RequestReader::Phase::body);
  EXPECT_TRUE(reader.take_continue());
  EXPECT_FALSE(reader.take_continue());
  reader.feed("abc");
  EXPECT_EQ(reader.advance(), Status::complete);
  EXPECT_EQ(reader.take().request.body, "abc");
  EXPECT_EQ(reader.phase(), RequestReader::Phase::idle);
}

std::string gunzip(const std::string& data) {
  z_stream z{};
  inflateInit2(&z, 15 + 16);
  std::string out(1 << 20, '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  z.avail_in = uInt(data.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = uInt(out.size());
  inflate(&z, Z_FINISH);
  out.resize(z.total_out);
  inflateEnd(&z);
  return out;
}

TEST(ServerHttpWire, ResponsesAreFramedHere) {
  HttpResponse r;
  r.body = R"({"a": 1})";
  r.set_header("Cache-Control", "no-store");
  r.set_header("Content-Length", "999");  // framing is the writer's: dropped
  r.set_header("X-Bad", "a\r\nInjected: 1");  // a header that would split the head: dropped
  EXPECT_EQ(write_response(r, {.keep_alive = true}),
            "HTTP/1.1 200 OK\r\nCache-Control: no-store\r\nContent-Type: application/json\r\nContent-Length: 8\r\n"
            "Connection: keep-alive\r\n\r\n{\"a\": 1}");
  EXPECT_EQ(write_response(r, {.keep_alive = false, .head = true}),
            "HTTP/1.1 200 OK\r\nCache-Control: no-store\r\nContent-Type: application/json\r\nContent-Length: 8\r\n"
            "Connection: close\r\n\r\n");
  HttpResponse none;
  none.status = 204;
  EXPECT_EQ(write_response(none, {}), "HTTP/1.1 204 No Content\r\nConnection: keep-alive\r\n\r\n");

  HttpResponse text;
  text.content_type = "text/html; charset=utf-8";
  for (int i = 0; i < 200; ++i) text.body += "<p>line " + std::to_string(i) + "</p>\n";
  const std::string zipped = write_response(text, {.accepts_gzip = true});
  ASSERT_NE(zipped.find("Content-Encoding: gzip\r\n"), std::string::npos);
  EXPECT_EQ(gunzip(zipped.substr(zipped.find("\r\n\r\n") + 4)), text.body);
  const std::string plain = write_response(text, {.accepts_gzip = false});
  EXPECT_EQ(plain.find("Content-Encoding"), std::string::npos);
  HttpResponse image;
  image.content_type = "image/jpeg";
  image.body = std::string(4096, 'j');
  EXPECT_EQ(write_response(image, {.accepts_gzip = true}).find("Content-Encoding"), std::string::npos)
      << "only text, JSON and JavaScript are compressed";
  EXPECT_EQ(error_bytes(408, "slow").substr(0, 30), "HTTP/1.1 408 Request Timeout\r\n");
  EXPECT_NE(error_bytes(408, "slow").find("Connection: close\r\n"), std::string::npos);
}

}  // namespace
}  // namespace strata::server::wire
