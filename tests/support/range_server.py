#!/usr/bin/env python3
"""A small HTTP server with Range support for the remote-file tests (python/tests/test_remote.py,
tests/io/test_http_source.cpp). Serves the files of one folder on 127.0.0.1 at a free port,
prints "PORT <n>" on stdout once it listens, and runs until killed. An optional second argument
delays every answer by that many milliseconds (a link's round trip, for benchmarks).

The first path component chooses how it behaves, so one server covers every case:
  /ok/NAME        ranges answered with 206 and Content-Range (a range past the end is clipped)
  /norange/NAME   Range ignored: 200 with the whole file
  /truncate/NAME  the file cut to half its size (Content-Range gives the shorter total)
  /reset/NAME     206 headers, half the body, then the connection reset, on every request
  /flaky/NAME     the first request for each range answered 503, repeats as /ok
  /__stats        JSON {"requests": n, "bytes": body bytes sent} since the last /__clear
  /__clear        zeroes the counters
NAME may name a file in a subfolder (a Zarr store's keys). Anything else, a missing file or a
path with "..": 404.
"""

import json
import os
import re
import socket
import struct
import sys
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

ROOT = sys.argv[1] if len(sys.argv) > 1 else "."
DELAY_S = float(sys.argv[2]) / 1000 if len(sys.argv) > 2 else 0.0
LOCK = threading.Lock()
STATS = {"requests": 0, "bytes": 0}
FAILED_ONCE = set()  # the (path, Range) pairs /flaky has refused


def count(requests=0, sent=0):
    with LOCK:
        STATS["requests"] += requests
        STATS["bytes"] += sent


def read(path, offset, size):
    with open(path, "rb") as f:
        f.seek(offset)
        return f.read(size)


class Handler(BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"

    def log_message(self, *args):
        pass

    def setup(self):
        super().setup()
        # Headers and body leave in separate writes: without this, Nagle's algorithm and the
        # client's delayed ACK hold every answer back ~40 ms.
        self.connection.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def finish(self):
        try:
            super().finish()
        except OSError:  # the socket a /reset answer closed
            pass

    def reply(self, status, body=b"", headers=(), counted=True):
        self.send_response(status)
        for name, value in headers:
            self.send_header(name, value)
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)
        if counted:
            count(sent=len(body))

    def do_GET(self):
        if self.path == "/__stats":
            with LOCK:
                body = json.dumps({"requests": STATS["requests"], "bytes": STATS["bytes"]}).encode()
            return self.reply(200, body, [("Content-Type", "application/json")], counted=False)
        if self.path == "/__clear":
            with LOCK:
                STATS.update(requests=0, bytes=0)
            return self.reply(200, b"{}", counted=False)
        count(requests=1)
        if DELAY_S:
            time.sleep(DELAY_S)
        parts = self.path.lstrip("/").split("/", 1)
        if len(parts) != 2 or parts[0] not in ("ok", "norange", "truncate", "reset", "flaky"):
            return self.reply(404, b"not found")
        mode, name = parts
        path = os.path.join(ROOT, name)
        if ".." in name.split("/") or not os.path.isfile(path):
            return self.reply(404, b"not found")
        size = os.path.getsize(path) // (2 if mode == "truncate" else 1)
        if mode == "flaky":
            key = (self.path, self.headers.get("Range", ""))
            with LOCK:
                fail = key not in FAILED_ONCE
                FAILED_ONCE.add(key)
            if fail:
                return self.reply(503, b"busy")
        match = re.fullmatch(r"bytes=(\d+)-(\d+)", self.headers.get("Range", ""))
        if mode == "norange" or not match:
            return self.reply(200, read(path, 0, size))
        first, last = int(match.group(1)), min(int(match.group(2)), size - 1)
        if first >= size:
            return self.reply(416, b"", [("Content-Range", f"bytes */{size}")])
        body = read(path, first, last + 1 - first)
        if mode == "reset":
            return self.reset(first, last, size, body)
        self.reply(206, body, [("Content-Range", f"bytes {first}-{last}/{size}")])

    def reset(self, first, last, total, body):
        self.send_response(206)
        self.send_header("Content-Range", f"bytes {first}-{last}/{total}")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body[: len(body) // 2])
        self.wfile.flush()
        count(sent=len(body) // 2)
        # SO_LINGER 0: close() sends a reset, not an orderly end.
        self.connection.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        self.connection.close()
        self.close_connection = True


class Server(ThreadingHTTPServer):
    daemon_threads = True

    def handle_error(self, request, client_address):
        pass  # clients that stop reading a /norange answer, resets: expected here


def main():
    server = Server(("127.0.0.1", 0), Handler)
    print(f"PORT {server.server_address[1]}", flush=True)
    server.serve_forever()


if __name__ == "__main__":
    main()
