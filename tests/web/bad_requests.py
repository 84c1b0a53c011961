#!/usr/bin/python3
"""Sends rutd's live view requests it must refuse, over raw sockets (no HTTP library's politeness), and
checks each answer: a 4xx status line, nothing from outside the page's fixed set, and the server still
answering properly afterwards.

usage: bad_requests.py HOST PORT TOKEN REPORT_JSON

Prints one line per case; exits 0 and writes {"cases": N, "failed": F, "good_after": bool, ...}."""
import json
import socket
import sys

HOST, PORT, TOKEN, REPORT = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
SECRET_MARKERS = [b"root:x:0:0", b"[boot loader]", b"BEGIN PRIVATE KEY", TOKEN.encode()]


def exchange(raw, timeout=10.0):
    """Sends raw bytes, reads until the server closes; returns (status or None, whole answer)."""
    s = socket.create_connection((HOST, PORT), timeout=timeout)
    try:
        # Not half-closed after the request: cpp-httplib takes a closed read side for a client gone.
        s.sendall(raw)
        data = b""
        while True:
            try:
                chunk = s.recv(65536)
            except (ConnectionResetError, socket.timeout):
                break
            if not chunk:
                break
            data += chunk
    except (BrokenPipeError, ConnectionResetError):
        data = b""
    finally:
        s.close()
    status = None
    if data.startswith(b"HTTP/1."):
        try:
            status = int(data.split(b" ", 2)[1])
        except ValueError:
            pass
    return status, data


def get(path, headers=(), token=True):
    lines = ["GET %s HTTP/1.1" % path, "Host: %s:%d" % (HOST, PORT), "Connection: close"]
    if token:
        lines.append("Authorization: Bearer " + TOKEN)
    lines += list(headers)
    return ("\r\n".join(lines) + "\r\n\r\n").encode("latin-1")


CASES = [
    # (name, raw request, accepted statuses)
    ("unknown path", get("/nothing-here"), {404}),
    ("a file's path", get("/etc/passwd"), {404}),
    ("traversal", get("/../../../../etc/passwd"), {400, 404}),
    ("encoded traversal", get("/%2e%2e/%2e%2e/etc/passwd"), {400, 404}),
    ("double-encoded traversal", get("/%252e%252e/etc/passwd"), {400, 404}),
    ("traversal under api", get("/api/../../etc/shadow"), {400, 404}),
    ("backslash traversal", get("/..%5c..%5cetc%5cpasswd"), {400, 404}),
    ("encoded NUL", get("/index.html%00.jpg"), {400, 404}),
    ("absolute form", b"GET http://example.com/etc/passwd HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " +
     TOKEN.encode() + b"\r\nConnection: close\r\n\r\n", {400, 404}),
    ("huge header", get("/", ["X-Filler: " + "a" * 100000]), {400, 413, 414, 431}),
    ("many headers", get("/", ["X-H%d: v" % i for i in range(2000)]), {400, 413, 431}),
    ("huge path", get("/" + "a" * 100000), {400, 404, 414, 431}),
    ("write method", b"POST /api/live.json HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " + TOKEN.encode() +
     b"\r\nContent-Length: 4\r\nConnection: close\r\n\r\nabcd", {400, 405}),
    ("delete", b"DELETE / HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " + TOKEN.encode() +
     b"\r\nConnection: close\r\n\r\n", {400, 405}),
    ("huge body", b"PUT / HTTP/1.1\r\nHost: x\r\nContent-Length: 100000000\r\nConnection: close\r\n\r\n" + b"x" * 10000,
     {400, 405, 413}),
    ("unknown method", b"BREW / HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n", {400, 405}),
    ("garbage", b"\x16\x03\x01\x02\x00\x01\x00\x01\xfc\x03\x03" + bytes(range(256)) + b"\r\n\r\n", {400, None}),
    ("no token", get("/api/live.json", token=False), {401}),
    ("no token for the data", get("/api/image/left.jpg", token=False), {401}),
    ("wrong token", get("/api/live.json", ["Authorization: Bearer x" + TOKEN[1:]], token=False), {403}),
    ("wrong token in the query", get("/api/live.json?token=not-the-token-at-all", token=False), {403}),
    ("token of another scheme", get("/api/live.json", ["Authorization: Basic " + TOKEN], token=False), {401}),
]


def main():
    report = {"cases": 0, "failed": 0, "leaks": 0}
    for name, raw, allowed in CASES:
        status, data = exchange(raw)
        leak = any(m in data for m in SECRET_MARKERS)
        ok = status in allowed and not leak and (status is None or 400 <= status < 500)
        report["cases"] += 1
        report["failed"] += 0 if ok else 1
        report["leaks"] += 1 if leak else 0
        print("%-28s -> %s %s" % (name, status, "ok" if ok else "FAILED (allowed %s%s)" % (
            sorted(a for a in allowed if a), ", body leaks a secret" if leak else "")))
    # Still answering, and properly, with the token.
    status, data = exchange(get("/api/live.json"))
    report["good_after"] = status == 200 and data.rstrip().endswith(b"}")
    print("good request afterwards    -> %s" % status)
    with open(REPORT, "w") as f:
        f.write(json.dumps(report, separators=(",", ":")) + "\n")


if __name__ == "__main__":
    main()
