#!/usr/bin/env python3
"""A file server for download tests: Range requests and scripted faults (stdlib only).

    python3 http_server.py --root DIR --port-file FILE [--faults FILE] [--log FILE]

Binds 127.0.0.1 on a free port and writes the port to --port-file (temp + rename) once
listening. GET/HEAD serve files under --root with Content-Length and Accept-Ranges: bytes;
a single "Range: bytes=a-" or "bytes=a-b" gets 206 + Content-Range (416 when out of range);
other Range forms are ignored (200). Missing files are 404; paths escaping the root 403.

--faults names a JSON file re-read on every request (missing = no faults):
    {"/url/path": [{"mode": "...", "after": N}, ...], ...}
The list for a path is consumed one fault per request to that path, in order; once used up,
requests succeed. The count of used faults is kept per path and restarts from 0 whenever the
faults file's content changes. Modes ("after" defaults to 0):
    "500", "404"      answer that status
    "truncate"        full Content-Length, only `after` body bytes, then close
    "flip"            whole body, the byte at file offset `after` XOR 0xFF
    "slow_then_drop"  `after` body bytes, sleep 0.2 s, close
    "norange"         ignore Range: 200 with the whole file
    "hang"            headers + `after` body bytes, then sleep forever
--log appends one JSON line per request, written and flushed before the answer is sent:
    {"path": ..., "range": header or null, "status": N, "fault": mode or null}
"""
import argparse
import json
import os
import re
import socket
import threading
import time
import urllib.parse
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

ARGS = None
LOCK = threading.Lock()
FAULTS_TEXT = None  # the faults file content the counters belong to
USED = {}  # url path -> faults consumed


def next_fault(path):
    """The fault for this request to `path`, or None."""
    global FAULTS_TEXT
    if not ARGS.faults:
        return None
    try:
        with open(ARGS.faults, encoding="utf-8") as f:
            text = f.read()
    except FileNotFoundError:
        text = ""
    with LOCK:
        if text != FAULTS_TEXT:
            FAULTS_TEXT = text
            USED.clear()
        faults = json.loads(text).get(path, []) if text.strip() else []
        used = USED.get(path, 0)
        if used >= len(faults):
            return None
        USED[path] = used + 1
        return faults[used]


def log(entry):
    if not ARGS.log:
        return
    with LOCK, open(ARGS.log, "a", encoding="utf-8") as f:
        f.write(json.dumps(entry) + "\n")
        f.flush()


class Handler(BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"

    def log_message(self, *args):  # quiet: the JSON log is the record
        pass

    def do_HEAD(self):
        self.serve(head=True)

    def do_GET(self):
        self.serve(head=False)

    def answer(self, status, fault, body=b""):
        # Logged before answering, so a client that has its answer always finds the line.
        log({"path": self.url_path, "range": self.headers.get("Range"), "status": status,
             "fault": fault})
        self.send_response(status)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Connection", "close")
        self.end_headers()
        if body and self.command != "HEAD":
            self.wfile.write(body)
        self.close_connection = True

    def drop(self):
        """Closes the connection abruptly, whatever the headers promised."""
        self.wfile.flush()
        try:
            self.connection.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self.close_connection = True

    def serve(self, head):
        self.url_path = urllib.parse.unquote(urllib.parse.urlsplit(self.path).path)
        try:
            fault = next_fault(self.url_path)
        except (ValueError, AttributeError, TypeError) as e:  # a broken faults file
            return self.answer(500, "bad-faults", f"bad faults file: {e}\n".encode())
        mode = fault.get("mode") if fault else None
        after = int(fault.get("after", 0)) if fault else 0
        if mode in ("500", "404"):
            return self.answer(int(mode), mode, b"fault\n")

        root = os.path.realpath(ARGS.root)
        target = os.path.realpath(os.path.join(root, self.url_path.lstrip("/")))
        if target != root and not target.startswith(root + os.sep):
            return self.answer(403, mode, b"forbidden\n")
        if not os.path.isfile(target):
            return self.answer(404, mode, b"not found\n")
        size = os.path.getsize(target)

        status, start, end = 200, 0, size - 1
        rng = self.headers.get("Range")
        m = re.fullmatch(r"bytes=(\d+)-(\d*)", rng.strip()) if rng else None
        if m and mode != "norange":
            start = int(m.group(1))
            end = min(int(m.group(2)), size - 1) if m.group(2) else size - 1
            if start >= size or end < start:
                log({"path": self.url_path, "range": rng, "status": 416, "fault": mode})
                self.send_response(416)
                self.send_header("Content-Range", f"bytes */{size}")
                self.send_header("Content-Length", "0")
                self.send_header("Connection", "close")
                self.end_headers()
                self.close_connection = True
                return
            status = 206
        length = end - start + 1

        log({"path": self.url_path, "range": rng, "status": status, "fault": mode})
        self.send_response(status)
        self.send_header("Content-Length", str(length))
        self.send_header("Accept-Ranges", "bytes")
        if status == 206:
            self.send_header("Content-Range", f"bytes {start}-{end}/{size}")
        self.send_header("Connection", "close")
        self.end_headers()
        self.close_connection = True
        if head:
            return
        with open(target, "rb") as f:
            f.seek(start)
            body = f.read(length)
        try:
            if mode == "flip":
                if start <= after <= end:
                    i = after - start
                    body = body[:i] + bytes([body[i] ^ 0xFF]) + body[i + 1:]
                self.wfile.write(body)
            elif mode in ("truncate", "slow_then_drop", "hang"):
                self.wfile.write(body[:after])
                self.wfile.flush()
                if mode == "slow_then_drop":
                    time.sleep(0.2)
                elif mode == "hang":
                    while True:
                        time.sleep(3600)
                self.drop()
            else:
                self.wfile.write(body)
        except (BrokenPipeError, ConnectionResetError):
            self.close_connection = True


def main():
    global ARGS
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", required=True)
    parser.add_argument("--port-file", required=True)
    parser.add_argument("--faults")
    parser.add_argument("--log")
    ARGS = parser.parse_args()
    server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    server.daemon_threads = True  # hung handlers must not keep the process alive
    tmp = f"{ARGS.port_file}.tmp.{os.getpid()}"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(f"{server.server_address[1]}\n")
    os.replace(tmp, ARGS.port_file)
    server.serve_forever()


if __name__ == "__main__":
    main()
