#!/usr/bin/env python3
"""A hostile-input campaign against the built `strata` program, its server and its Python module
(docs/reliability.md, "The campaign"). Each class of abuse runs a few hundred commands on small
files made here and checks what every one of them must hold:

  * no crash (a signal, an abort, a sanitizer report) and no hang (a per-run time limit);
  * a refusal is exit code 1 or 2 with one `error:` line in Strata's words, never a library's
    (JSON parser, zstd, pybind11, CLI11, "terminate called", a raw `what()`);
  * exit 0 after corruption only with the same result as the intact file (no silent wrong decode);
  * inputs unchanged (compared by content hash), whatever the outputs are called;
  * no temporary or partial file left behind (`.tmp`, `.part`), even after SIGTERM or SIGINT;
  * bounded temporary space for inputs that declare huge volumes;
  * a server that keeps answering while slow clients trickle headers, answers pipelined
    requests, refuses conflicting Content-Length headers, and does not share its port.

Usage: scripts/reliability_campaign.py [--strata build/release/strata]
           [--pythonpath build/release/python] [--seed 1] [--mutations 40] [--only CLASS ...]
           [--json report.json] [--keep]
Exits 1 when any class has a finding; prints one line per class and every finding.
"""

import argparse
import gzip
import hashlib
import json
import os
import random
import re
import shutil
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

# Wording of the libraries Strata uses: none of it may reach a user.
LIBRARY_TEXT = [
    r"parse error at", r"syntax error while parsing", r"\[json\.exception", r"Data corruption detected",
    r"Unknown frame descriptor", r"Unable to cast", r"File is actually a directory", r"terminate called",
    r"what\(\):", r"std::bad_alloc", r"basic_string", r"vector::_M", r"Segmentation fault", r"AddressSanitizer",
    r"runtime error:", r"Traceback \(most recent call last\)", r"File does not exist:",
]
LIBRARY_RE = re.compile("|".join(LIBRARY_TEXT))
LEFTOVER_RE = re.compile(r"(\.tmp|\.part)$|^\.[^/]*\.(tmp|part)")
RUN_TIMEOUT_S = 60


class Campaign:
    def __init__(self, strata, pythonpath, seed, work):
        # Commands run in the work folder: a path given relative to here must still find them.
        self.strata = str(Path(strata).resolve()) if os.sep in str(strata) else str(strata)
        self.pythonpath = str(Path(pythonpath).resolve())
        self.rng = random.Random(seed)
        self.work = Path(work)
        self.findings = []
        self.runs = 0

    # -- running and judging ------------------------------------------------------------------

    def run(self, args, cwd=None, env=None, timeout=RUN_TIMEOUT_S):
        """Runs strata ARGS; returns (returncode, stdout, stderr); a hang is returncode None."""
        self.runs += 1
        try:
            p = subprocess.run([self.strata, "--progress", "none", *map(str, args)], cwd=cwd, env=env,
                               capture_output=True, text=True, errors="replace", timeout=timeout)
            return p.returncode, p.stdout, p.stderr
        except subprocess.TimeoutExpired:
            return None, "", ""

    def finding(self, cls, what, detail=""):
        self.findings.append({"class": cls, "what": what, "detail": detail[:400]})

    def judge(self, cls, args, rc, out, err):
        """The checks every run must pass; returns True when the run refused cleanly or succeeded."""
        cmd = "strata " + " ".join(map(str, args))
        if rc is None:
            self.finding(cls, f"hang (> {RUN_TIMEOUT_S} s): {cmd}")
            return False
        if rc < 0 or rc >= 128:
            self.finding(cls, f"crash (signal {-rc if rc < 0 else rc - 128}): {cmd}", err)
            return False
        if LIBRARY_RE.search(err) or LIBRARY_RE.search(out):
            self.finding(cls, f"library text: {cmd}", err or out)
        if rc not in (0, 1, 2):
            self.finding(cls, f"exit code {rc}: {cmd}", err)
        if rc != 0 and not err.startswith("error:"):
            self.finding(cls, f"refusal without an error line: {cmd}", err)
        return True

    def leftovers(self, cls, folder, what):
        for p in Path(folder).rglob("*"):
            if LEFTOVER_RE.search(p.name):
                self.finding(cls, f"leftover {p.name} after {what}")
                try:
                    shutil.rmtree(p) if p.is_dir() else p.unlink()
                except OSError:
                    pass

    # -- inputs ---------------------------------------------------------------------------------

    def make_inputs(self):
        d = self.work / "inputs"
        d.mkdir(parents=True, exist_ok=True)
        s = self.run
        s(["generate", "prisms", "--size", "40", "-o", d / "prisms.nrrd"])
        s(["generate", "superpixels", "--size", "40", "--count", "30", "-o", d / "cells.nrrd"])
        files = {
            "ta-bricked": (["compress", d / "prisms.nrrd", "-o", d / "fixed.strata", "--brick", "8"], "scalar"),
            "error-target": (["compress", d / "prisms.nrrd", "-o", d / "psnr.strata", "--psnr", "40", "--brick", "8"],
                             "scalar"),
            "ta-global": (["compress", d / "prisms.nrrd", "-o", d / "global.strata", "--codec", "ta-global",
                           "--brick", "8"], "scalar"),
            "mixture-graph": (["labels", "encode", d / "cells.nrrd", "-o", d / "cells.strata", "--normals"], "labels"),
        }
        self.write_4d_nrrd(d / "series.nrrd")
        files["volume-set"] = (["compress", d / "series.nrrd", "--all-volumes", "-o", d / "set.strata", "--brick", "8"],
                               "set")
        made = {}
        for name, (args, kind) in files.items():
            rc, _, err = self.run(args)
            if rc != 0:
                self.finding("setup", f"cannot make the {name} input", err)
                continue
            made[name] = (Path(args[args.index("-o") + 1]), kind)
        return made

    def write_4d_nrrd(self, path, dims=(24, 20, 16), count=2):
        """Two time points of a small u16 volume, the last axis the series."""
        x, y, z = dims
        data = bytearray()
        for t in range(count):
            for k in range(z):
                for j in range(y):
                    data += struct.pack(f"<{x}H", *[(i * 37 + j * 11 + k * 5 + t * 900) % 4000 for i in range(x)])
        header = (f"NRRD0004\ntype: uint16\ndimension: 4\nsizes: {x} {y} {z} {count}\nkinds: space space space list\n"
                  "endian: little\nencoding: raw\n\n")
        Path(path).write_bytes(header.encode() + bytes(data))

    # -- class 1: corruption of every codec and part of the file ---------------------------------

    def decode_commands(self, kind, path, out):
        if kind == "labels":
            return [["info", path], ["labels", "decode", path, "-o", out],
                    ["labels", "query", path, "--box", "0,0,0:20,20,20", "--top", "3"]]
        extra = ["--volume", "1"] if kind == "set" else []
        return [["info", path, *extra], ["decompress", path, "-o", out, *extra],
                ["decompress", path, "-o", out, "--level", "1", *extra]]

    def corruption(self, inputs, mutations):
        cls = "corruption"
        d = self.work / cls
        d.mkdir(exist_ok=True)
        for name, (path, kind) in inputs.items():
            intact = path.read_bytes()
            refs = []
            for args in self.decode_commands(kind, path, d / "ref.nrrd"):
                rc, out, _ = self.run(args)
                refs.append((rc, self.output_digest(args, out)))
                (d / "ref.nrrd").unlink(missing_ok=True)
            for m in range(mutations):
                data, how = self.mutate(intact)
                bad = d / f"{name}-{m}.strata"
                bad.write_bytes(data)
                for i, args in enumerate(self.decode_commands(kind, bad, d / "out.nrrd")):
                    rc, out, err = self.run(args)
                    if not self.judge(cls, args, rc, out, err):
                        continue
                    ref_rc, ref_digest = refs[i]
                    if rc == 0 and ref_rc == 0 and args[0] != "info" and self.output_digest(args, out) != ref_digest:
                        self.finding(cls, f"silent wrong decode of {name} after {how}: strata {' '.join(map(str, args[:2]))}")
                    for f in d.glob("out*.nrrd"):
                        f.unlink()
                self.leftovers(cls, d, f"{name} {how}")
                bad.unlink()

    def output_digest(self, args, stdout):
        if "-o" in args:
            out = Path(args[args.index("-o") + 1])
            return self.volume_digest(out) if out.exists() else None
        timeless = re.sub(r"[0-9.]+ ms", "", stdout)  # query reports carry their timings
        return hashlib.sha256(timeless.encode()).hexdigest()

    def volume_digest(self, nrrd):
        """The samples of a written NRRD (the header holds the file name, which differs)."""
        raw = Path(nrrd).read_bytes()
        cut = raw.find(b"\n\n")
        body = raw[cut + 2:]
        try:
            body = gzip.decompress(body)
        except OSError:
            pass
        return hashlib.sha256(body).hexdigest()

    def mutate(self, data):
        data = bytearray(data)
        header_end, tail = 64, max(64, len(data) - 4096)
        kind = self.rng.choice(["bit", "byte", "zero4", "truncate", "header", "tail", "append"])
        if kind == "truncate":
            n = self.rng.randrange(1, len(data))
            return bytes(data[:n]), f"truncation to {n} bytes"
        if kind == "append":
            return bytes(data) + bytes(self.rng.randrange(256) for _ in range(100)), "100 bytes appended"
        if kind == "header":
            pos = self.rng.randrange(0, header_end)
        elif kind == "tail":  # metadata and index
            pos = self.rng.randrange(tail, len(data))
        else:
            pos = self.rng.randrange(0, len(data))
        if kind == "bit":
            data[pos] ^= 1 << self.rng.randrange(8)
        elif kind == "zero4":
            data[pos:pos + 4] = bytes(len(data[pos:pos + 4]))
        else:
            data[pos] = (data[pos] + self.rng.randrange(1, 256)) % 256
        return bytes(data), f"{kind} at byte {pos}"

    # -- class 2: forged section tables (checksums recomputed where the forger can) --------------

    def forged_sections(self, inputs):
        cls = "forged-sections"
        d = self.work / cls
        d.mkdir(exist_ok=True)
        for name, (path, kind) in inputs.items():
            intact = path.read_bytes()
            meta_off, meta_size = struct.unpack_from("<QQ", intact, 32)
            meta = json.loads(intact[meta_off:meta_off + meta_size])
            sections = sorted(meta.get("sections", {}))
            cases = []
            if len(sections) >= 2:
                a, b = (sections[-2], sections[-1]) if kind == "set" else (sections[0], sections[1])
                forged = json.loads(json.dumps(meta))
                forged["sections"][a], forged["sections"][b] = meta["sections"][b], meta["sections"][a]
                cases.append((f"sections {a} and {b} swapped", forged))
            for s in sections:
                forged = json.loads(json.dumps(meta))
                forged["sections"][s]["crc32c"] = 0
                cases.append((f"section {s} checksum 0", forged))
            for how, forged in cases:
                data = self.with_metadata(intact, forged)
                if data is None:
                    continue
                bad = d / f"{name}.strata"
                bad.write_bytes(data)
                forged_names = [s for s in sections if forged["sections"][s] != meta["sections"][s]]
                readers = {tuple(map(str, a)): a for s in forged_names for a in self.section_readers(kind, bad, d, s)}
                # Only a command that reads a forged section must refuse; the others may succeed.
                for args in readers.values():
                    rc, out, err = self.run(args)
                    if self.judge(cls, args, rc, out, err) and rc == 0:
                        self.finding(cls, f"accepted: {name} with {how}: strata {' '.join(map(str, args))}")
                self.leftovers(cls, d, f"{name} {how}")

    def section_readers(self, kind, path, d, section):
        """The commands that read `section` of `path`."""
        if kind == "labels" and section == "normals":
            return [["render", path, "--lighting", "normals", "--size", "32x32", "-o", d / "f.png"]]
        if kind == "set" and section.startswith("volume_"):
            return [["decompress", path, "--volume", section[len("volume_"):], "-o", d / "v.nrrd"]]
        return self.decode_commands(kind, path, d / "out.nrrd")[1:2]

    def with_metadata(self, data, meta):
        """`data` with `meta` as its metadata (same place, padded) and the metadata and header
        checksums recomputed; None when it does not fit before the index."""
        index_off, _, meta_off, meta_size = struct.unpack_from("<QQQQ", data, 16)
        text = json.dumps(meta, separators=(",", ":")).encode()
        room = (index_off if index_off > meta_off else len(data)) - meta_off
        if len(text) > room:
            return None
        out = bytearray(data)
        out[meta_off:meta_off + room] = text + bytes(room - len(text))
        struct.pack_into("<Q", out, 40, len(text))
        struct.pack_into("<I", out, 52, crc32c(text))
        struct.pack_into("<I", out, 60, crc32c(bytes(out[:60])))
        return bytes(out)

    # -- class 3: outputs that alias inputs through every indirection -----------------------------

    def aliasing(self, inputs):
        cls = "aliasing"
        d = self.work / cls
        d.mkdir(exist_ok=True)
        src = self.work / "inputs" / "prisms.nrrd"
        self.run(["convert", src, d / "hb.nhdr", "--uncompressed"])
        data_file = next((p for p in d.iterdir() if p.name.startswith("hb") and p.suffix != ".nhdr"), None)
        self.run(["convert", src, d / "v.raw"])
        self.run(["convert", src, d / "slices.tif"])
        self.run(["convert", src, d / "img.ome.zarr"])
        shutil.copy(inputs["ta-bricked"][0], d / "a.strata") if "ta-bricked" in inputs else None
        shutil.copy(inputs["mixture-graph"][0], d / "l.strata") if "mixture-graph" in inputs else None
        (d / "link.nrrd").symlink_to(d / "hb.nhdr") if (d / "hb.nhdr").exists() else None
        if data_file:
            os.link(data_file, d / "hard.raw")
        shutil.copy(src, d / "p.nrrd")
        cases = [
            ["convert", d / "hb.nhdr", data_file], ["convert", d / "hb.nhdr", d / "hard.raw"],
            ["convert", d / "link.nrrd", d / "hb.nhdr"], ["convert", d / "p.nrrd", d / "./p.nrrd"],
            ["convert", d / "v.raw", d / "v.raw"], ["convert", d / "v.raw", d / "v.raw.json"],
            ["convert", d / "img.ome.zarr", d / "img.ome.zarr"], ["convert", d / "img.ome.zarr", d / "img.ome.zarr" / "x.nrrd"],
            ["compress", d / "hb.nhdr", "-o", data_file], ["compress", d / "p.nrrd", "-o", d / "p.nrrd"],
            ["decompress", d / "a.strata", "-o", d / "a.strata"], ["decompress", d / "link.nrrd", "-o", d / "hb.nhdr"],
            ["labels", "encode", d / "p.nrrd", "-o", d / "p.nrrd"], ["labels", "decode", d / "l.strata", "-o", d / "l.strata"],
        ]
        cases = [c for c in cases if all(a is not None for a in c)]
        for args in cases:
            before = self.tree_digest(d)
            rc, out, err = self.run(args)
            self.judge(cls, args, rc, out, err)
            after = self.tree_digest(d)
            changed = sorted(k for k in before if before[k] != after.get(k))
            if changed:
                self.finding(cls, f"input rewritten ({', '.join(changed)}): strata {' '.join(map(str, args))}")
                return  # the inputs are gone: later cases would judge other files
            if rc == 0:
                self.finding(cls, f"accepted an output that is an input: strata {' '.join(map(str, args))}")
            self.leftovers(cls, d, " ".join(map(str, args[:2])))

    def tree_digest(self, folder):
        return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
                for p in sorted(Path(folder).rglob("*")) if p.is_file() and not p.is_symlink()}

    # -- class 4: bombs: small files declaring huge volumes --------------------------------------

    def bombs(self):
        cls = "bombs"
        d = self.work / cls
        d.mkdir(exist_ok=True)
        zeros = bytes(1 << 20)
        stream = gzip.compress(zeros * 256, compresslevel=9)  # 256 MiB of zeros in about 256 KiB
        cases = {
            "short": (1024, 1024, 1024),   # declares 1 GiB, holds 256 MiB: refused after reading
            "huge": (100000, 100000, 100000),  # declares 10^15 bytes: refused up front
        }
        for name, (x, y, z) in cases.items():
            path = d / f"{name}.nrrd"
            path.write_bytes(f"NRRD0004\ntype: uint8\ndimension: 3\nsizes: {x} {y} {z}\nencoding: gzip\n\n".encode()
                             + stream)
            for args in (["info", path], ["convert", path, d / "out.nrrd"], ["compress", path, "-o", d / "out.strata"]):
                tmp = d / "tmp"
                tmp.mkdir(exist_ok=True)
                rc, out, err, peak = self.run_watching_temp(args, tmp)
                self.judge(cls, args, rc, out, err)
                cmd = f"strata {args[0]} {name}.nrrd"
                if rc == 0:
                    self.finding(cls, f"accepted a bomb: {cmd}")
                limit = 0 if name == "huge" else 64 << 20
                if peak > limit:  # every command reads these in z order: nothing to decode for random access
                    self.finding(cls, f"{peak >> 20} MiB written to TMPDIR by {cmd}")
                self.leftovers(cls, d, cmd)
                if folder_bytes(tmp):
                    self.finding(cls, f"TMPDIR not emptied after {cmd}")
                shutil.rmtree(tmp)
        # A valid file of 2 GiB of zeros in about 2 MB (the case): `info` reads it whole
        # and must not decode it to TMPDIR on the way.
        path = d / "full.nrrd"
        with open(path, "wb") as f:
            f.write(b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 1024 1024 2048\nencoding: gzip\n\n")
            with gzip.GzipFile(fileobj=f, mode="wb", compresslevel=9) as z:
                for _ in range(2048):
                    z.write(zeros)
        tmp = d / "tmp"
        tmp.mkdir(exist_ok=True)
        args = ["info", path]
        rc, out, err, peak = self.run_watching_temp(args, tmp)
        if self.judge(cls, args, rc, out, err) and rc != 0:
            self.finding(cls, "strata info full.nrrd refused a valid 2 GiB gzip file", err)
        if peak > 64 << 20:
            self.finding(cls, f"{peak >> 20} MiB written to TMPDIR by strata info full.nrrd")
        shutil.rmtree(tmp)
        path.unlink()

    def run_watching_temp(self, args, tmp):
        """run() with TMPDIR=`tmp`, sampling every 20 ms the bytes in it, unnamed temporaries
        (O_TMPFILE, or unlinked after creation: only the process's descriptors show them)
        included; returns (rc, stdout, stderr, peak bytes)."""
        self.runs += 1
        env = dict(os.environ, TMPDIR=str(tmp))
        peak = 0
        with subprocess.Popen([self.strata, "--progress", "none", *map(str, args)], env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, errors="replace") as p:
            collected = {}
            readers = [threading.Thread(target=lambda s=s, k=k: collected.__setitem__(k, s.read()))
                       for k, s in (("out", p.stdout), ("err", p.stderr))]
            for r in readers:
                r.start()
            start = time.monotonic()
            while p.poll() is None and time.monotonic() - start < RUN_TIMEOUT_S:
                peak = max(peak, folder_bytes(tmp) + open_bytes_under(p.pid, tmp))
                time.sleep(0.02)
            if p.poll() is None:
                p.kill()
                p.wait()
                rc = None
            else:
                rc = p.returncode
            for r in readers:
                r.join()
        return rc, collected.get("out", ""), collected.get("err", ""), peak

    # -- class 5: kills -----------------------------------------------------------------------------

    def kills(self, count):
        cls = "kills"
        d = self.work / cls
        d.mkdir(exist_ok=True)
        big = d / "big.nrrd"
        self.run(["generate", "prisms", "--size", "128", "-o", big])
        series = self.work / "inputs" / "series.nrrd"
        commands = [["compress", big, "-o", d / "k.strata", "--brick", "16"],
                    ["compress", series, "--all-volumes", "-o", d / "set.strata"],
                    ["convert", big, d / "k.nii.gz"], ["decompress", d / "ref.strata", "-o", d / "k2.nrrd"]]
        self.run(["compress", big, "-o", d / "ref.strata"])
        for i in range(count):
            args = commands[i % len(commands)]
            sig = self.rng.choice([signal.SIGTERM, signal.SIGINT, signal.SIGKILL])
            delay = self.rng.uniform(0.02, 0.6)
            p = subprocess.Popen([self.strata, "--progress", "none", *map(str, args)], stdout=subprocess.DEVNULL,
                                 stderr=subprocess.PIPE, text=True)
            time.sleep(delay)
            p.send_signal(sig)
            try:
                _, err = p.communicate(timeout=RUN_TIMEOUT_S)
            except subprocess.TimeoutExpired:
                p.kill()
                self.finding(cls, f"did not stop on {sig.name}: strata {' '.join(map(str, args))}")
                continue
            if p.returncode is not None and p.returncode < 0 and -p.returncode not in (signal.SIGTERM, signal.SIGINT,
                                                                                       signal.SIGKILL):
                self.finding(cls, f"crash (signal {-p.returncode}) on {sig.name}", err)
            what = f"{sig.name} after {delay:.2f} s of strata {args[0]} {Path(str(args[1])).name}"
            if sig == signal.SIGKILL:
                # Nothing can clean up after SIGKILL; the next run of the command must (and succeed).
                rc, out, err = self.run(args)
                if rc != 0:
                    self.finding(cls, f"the run after {what} failed", err)
            self.leftovers(cls, d, what)
            out = Path(str(args[args.index("-o") + 1] if "-o" in args else args[2]))
            if out.exists() and out.suffix == ".strata":
                rc, _, err = self.run(["info", out])
                if rc != 0:
                    self.finding(cls, f"a damaged output after {what}", err)
                out.unlink()

    # -- class 6: the server: slow and pipelining clients, bad headers, a busy port ----------------

    def server(self, inputs, slow_connections):
        cls = "server"
        d = self.work / cls
        d.mkdir(exist_ok=True)
        files = [str(p) for p, _ in inputs.values()][:2]
        p = subprocess.Popen([self.strata, "serve", *files, "--port", "0"], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
        port = None
        deadline = time.time() + 60
        while time.time() < deadline:
            line = p.stdout.readline()
            m = re.search(r"Serving on http://[^:]+:(\d+)", line)
            if m:
                port = int(m.group(1))
                break
        if not port:
            p.kill()
            self.finding(cls, "the server did not start", p.stderr.read())
            return
        try:
            self.slow_clients(cls, port, slow_connections)
            self.pipelining(cls, port)
            self.bad_headers(cls, port)
            self.busy_port(cls, port, files)
        finally:
            p.terminate()
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
                self.finding(cls, "the server did not stop on SIGTERM")
        self.unreadable_file(cls, d, inputs)

    def slow_clients(self, cls, port, count):
        sockets, stop = [], threading.Event()
        for _ in range(count):
            try:
                s = socket.create_connection(("127.0.0.1", port), timeout=5)
                s.sendall(b"GET /api/datasets HTTP/1.1\r\n")
                sockets.append(s)
            except OSError:
                break

        def trickle():
            n = 0
            while not stop.wait(2.0):
                n += 1
                for s in sockets:
                    try:
                        s.sendall(f"X-Slow-{n}: {n}\r\n".encode())
                    except OSError:
                        pass

        t = threading.Thread(target=trickle)
        t.start()
        try:
            time.sleep(1)
            for i in range(5):
                start = time.time()
                answer = http_exchange(port, b"GET /api/datasets HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n", 5)
                took = time.time() - start
                if not answer.startswith(b"HTTP/1.1 200"):
                    self.finding(cls, f"probe {i} not answered while {len(sockets)} slow clients trickle headers")
                elif took > 1.0:
                    self.finding(cls, f"probe {i} took {took:.2f} s while {len(sockets)} slow clients trickle headers")
                time.sleep(0.5)
        finally:
            stop.set()
            t.join()
            for s in sockets:
                s.close()

    def pipelining(self, cls, port):
        n = 50
        request = b"GET /api/datasets HTTP/1.1\r\nHost: x\r\n\r\n"
        answer = http_exchange(port, request * (n - 1) + request.replace(b"\r\n\r\n", b"\r\nConnection: close\r\n\r\n"),
                               20)
        got = answer.count(b"HTTP/1.1 200")
        if got != n:
            self.finding(cls, f"{got} of {n} pipelined requests answered")

    def bad_headers(self, cls, port):
        cases = {
            "conflicting Content-Length": b"POST /api/datasets/0/palette HTTP/1.1\r\nHost: x\r\nContent-Length: 2\r\n"
                                          b"Content-Length: 5\r\nConnection: close\r\n\r\n{}",
            "negative Content-Length": b"POST /api/datasets/0/palette HTTP/1.1\r\nHost: x\r\nContent-Length: -1\r\n"
                                       b"Connection: close\r\n\r\n",
            "Content-Length and chunked": b"POST /api/datasets/0/palette HTTP/1.1\r\nHost: x\r\nContent-Length: 2\r\n"
                                          b"Transfer-Encoding: chunked\r\nConnection: close\r\n\r\n{}",
        }
        for what, request in cases.items():
            answer = http_exchange(port, request, 5)
            status = answer[9:12]
            if not status.startswith(b"4"):
                self.finding(cls, f"{what}: answered {status.decode(errors='replace') or 'nothing'}, expected 4xx")

    def busy_port(self, cls, port, files):
        rc, out, err = self.run(["serve", files[0], "--port", port], timeout=10)
        if rc is None:
            self.finding(cls, f"a second server started on the busy port {port}")
        elif rc == 0 or "error:" not in err:
            self.finding(cls, f"a second server on the busy port {port}: exit {rc}", err)

    def unreadable_file(self, cls, d, inputs):
        if os.geteuid() == 0:
            bad = d / "broken.strata"
            bad.write_bytes(b"\x89STRATA\n" + bytes(100))
        else:
            bad = d / "locked.strata"
            bad.write_bytes(next(iter(inputs.values()))[0].read_bytes())
            bad.chmod(0)
        shutil.copy(next(iter(inputs.values()))[0], d / "good.strata")
        p = subprocess.Popen([self.strata, "serve", d, "--port", "0"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True)
        try:
            out, err = p.communicate(timeout=10)
            self.finding(cls, f"serve DIR with one unreadable file stopped: exit {p.returncode}", err)
        except subprocess.TimeoutExpired:
            p.terminate()
            out, err = p.communicate(timeout=20)
            if bad.name not in err:
                self.finding(cls, "serve DIR skipped an unreadable file without naming it", err)

    # -- class 7: hostile Python calls -----------------------------------------------------------

    PYTHON_CASES = {
        "non-contiguous view too large to copy": ("import numpy as np, resource\n"
            "resource.setrlimit(resource.RLIMIT_AS, (8 << 30, 8 << 30))\n"
            "v = np.lib.stride_tricks.as_strided(np.zeros(1, np.uint16), (2048,) * 3, (0, 0, 0))\n"
            "strata.compress(v, OUT)", "MemoryError"),
        "complex samples": ("import numpy as np\nstrata.compress(np.zeros((8, 8, 8), np.complex64), OUT)", None),
        "a 2-D array": ("import numpy as np\nstrata.compress(np.zeros((8, 8), np.uint8), OUT)", None),
        "a 0-d array": ("import numpy as np\nstrata.compress(np.array(3, np.uint8), OUT)", None),
        "an object array": ("import numpy as np\nstrata.compress(np.array([[[None]]], dtype=object), OUT)", None),
        "a string for an array": ("strata.compress('not an array', OUT)", None),
        "negative threads": ("strata.set_threads(-1)", "ValueError"),
        "a missing file": ("strata.open(OUT + '.missing')", None),
        "a directory as file": ("import os\nstrata.open(os.path.dirname(OUT))", None),
        "a corrupt file": ("open(OUT, 'wb').write(b'\\x89STRATA\\n' + bytes(200))\nstrata.open(OUT)", None),
        "a negative shape": ("strata.generate('prisms', (-1, 4, 4))", None),
        "a huge shape": ("strata.generate('prisms', (1 << 40, 1 << 40, 1 << 40))", None),
        "a byte-swapped array": ("import numpy as np\na = np.arange(512, dtype='>u2').reshape(8, 8, 8)\n"
            "strata.compress(a, OUT)\nassert (strata.open(OUT)[...] >= 0).all()\nraise ValueError('ok')", None),
    }

    def python_calls(self):
        cls = "python"
        d = self.work / cls
        d.mkdir(exist_ok=True)
        env = dict(os.environ, PYTHONPATH=self.pythonpath)
        for what, (code, expected) in self.PYTHON_CASES.items():
            program = (f"import strata, sys\nOUT = {str(d / 'p.strata')!r}\ntry:\n"
                       + "".join("    " + line + "\n" for line in code.split("\n"))
                       + "except Exception as e:\n"
                       "    print(','.join(c.__name__ for c in type(e).__mro__) + ': ' + str(e))\n    sys.exit(3)\n")
            self.runs += 1
            try:
                p = subprocess.run(["/usr/bin/python3", "-c", program], env=env, capture_output=True, text=True,
                                   timeout=RUN_TIMEOUT_S)
            except subprocess.TimeoutExpired:
                self.finding(cls, f"hang: {what}")
                continue
            if p.returncode < 0:
                self.finding(cls, f"the interpreter died (signal {-p.returncode}): {what}", p.stderr)
                continue
            if p.returncode == 0:
                continue  # accepted: fine when it is valid input
            message = p.stdout.strip()
            if p.returncode != 3:
                self.finding(cls, f"exit {p.returncode}: {what}", p.stderr)
            elif LIBRARY_RE.search(message):
                self.finding(cls, f"library text: {what}", message)
            elif expected and expected not in message.split(":")[0].split(","):
                self.finding(cls, f"{what}: {message.split(',')[0]}, expected {expected}", message)
            self.leftovers(cls, d, what)


def http_exchange(port, request, timeout):
    """Sends `request` on a new connection and returns everything read until the server closes
    it or `timeout` seconds pass."""
    data = b""
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=timeout) as s:
            s.sendall(request)
            deadline = time.time() + timeout
            while time.time() < deadline:
                s.settimeout(max(0.01, deadline - time.time()))
                chunk = s.recv(65536)
                if not chunk:
                    break
                data += chunk
    except OSError:
        pass
    return data


def open_bytes_under(pid, folder):
    """Bytes held by the files process `pid` has open under `folder`, deleted or unnamed ones too."""
    total = 0
    prefix = str(Path(folder).resolve())
    try:
        fds = os.listdir(f"/proc/{pid}/fd")
    except OSError:
        return 0
    for fd in fds:
        try:
            if os.readlink(f"/proc/{pid}/fd/{fd}").startswith(prefix):
                total += os.stat(f"/proc/{pid}/fd/{fd}").st_blocks * 512
        except OSError:
            pass
    return total


def folder_bytes(folder):
    total = 0
    for root, _, names in os.walk(folder):
        for n in names:
            try:
                total += os.lstat(os.path.join(root, n)).st_blocks * 512
            except OSError:
                pass
    return total


def crc32c(data):
    table = crc32c.table
    crc = 0xFFFFFFFF
    for b in data:
        crc = table[(crc ^ b) & 0xFF] ^ (crc >> 8)
    return crc ^ 0xFFFFFFFF


def _crc32c_table():
    table = []
    for i in range(256):
        c = i
        for _ in range(8):
            c = (c >> 1) ^ 0x82F63B78 if c & 1 else c >> 1
        table.append(c)
    return table


crc32c.table = _crc32c_table()

CLASSES = ["corruption", "forged-sections", "aliasing", "bombs", "kills", "server", "python"]


def main():
    root = Path(__file__).resolve().parent.parent
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--strata", default=root / "build/release/strata")
    parser.add_argument("--pythonpath", default=root / "build/release/python")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--mutations", type=int, default=40, help="corrupted copies per input file")
    parser.add_argument("--kills", type=int, default=24)
    parser.add_argument("--slow-connections", type=int, default=200)
    parser.add_argument("--only", nargs="*", choices=CLASSES, default=CLASSES)
    parser.add_argument("--json", help="write the report here")
    parser.add_argument("--keep", action="store_true", help="keep the work folder")
    a = parser.parse_args()
    work = tempfile.mkdtemp(prefix="strata-campaign-")
    c = Campaign(a.strata, a.pythonpath, a.seed, work)
    report = {"seed": a.seed, "classes": {}}
    started = time.time()
    inputs = c.make_inputs()
    steps = {
        "corruption": lambda: c.corruption(inputs, a.mutations),
        "forged-sections": lambda: c.forged_sections(inputs),
        "aliasing": lambda: c.aliasing(inputs),
        "bombs": c.bombs,
        "kills": lambda: c.kills(a.kills),
        "server": lambda: c.server(inputs, a.slow_connections),
        "python": c.python_calls,
    }
    for name in a.only:
        t0, runs0, found0 = time.time(), c.runs, len(c.findings)
        steps[name]()
        report["classes"][name] = {"runs": c.runs - runs0, "findings": len(c.findings) - found0,
                                   "seconds": round(time.time() - t0, 1)}
        print(f"{name:16} {c.runs - runs0:5} runs  {len(c.findings) - found0:3} findings  {time.time() - t0:6.1f} s",
              flush=True)
    report["findings"] = c.findings
    report["runs"] = c.runs
    report["seconds"] = round(time.time() - started, 1)
    for f in c.findings:
        print(f"FINDING [{f['class']}] {f['what']}" + (f"\n    {f['detail'].strip()}" if f["detail"] else ""))
    print(f"{c.runs} runs, {len(c.findings)} findings, {report['seconds']} s (work folder {work})")
    if a.json:
        Path(a.json).write_text(json.dumps(report, indent=1))
    if not a.keep:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if c.findings else 0


if __name__ == "__main__":
    sys.exit(main())
