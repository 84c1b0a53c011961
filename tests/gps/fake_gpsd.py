#!/usr/bin/env python3
"""A misbehaving gpsd for the fault tests: speaks gpsd's protocol on 127.0.0.1:PORT but serves, connection
by connection, the lines of SESSION files (one file per connection, in order), then closes the connection
(a gpsd that goes away mid-run). After the last session the final connection stays open until killed.
Lines are sent `--gap` seconds apart after the client's ?WATCH. Real gpsd cannot be made to send a
malformed report or a time jump on demand; this can.
"""
import argparse
import socket
import time


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--port", type=int, required=True)
    p.add_argument("--gap", type=float, default=0.05)
    p.add_argument("sessions", nargs="+")
    a = p.parse_args()
    server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    server.bind(("127.0.0.1", a.port))
    server.listen(1)
    i = 0
    while i < len(a.sessions):
        path = a.sessions[i]
        conn, _ = server.accept()
        conn.settimeout(5.0)
        try:
            conn.sendall(b'{"class":"VERSION","release":"3.22","rev":"3.22","proto_major":3,"proto_minor":14}\n')
            watch = conn.recv(4096)  # the client's ?WATCH={...};
        except (socket.timeout, OSError):
            watch = b""
        if not watch.startswith(b"?WATCH"):
            conn.close()  # a probe that only checked the port: not a session
            continue
        i += 1
        with open(path, "rb") as f:
            for line in f:
                conn.sendall(line.rstrip(b"\n") + b"\n")
                time.sleep(a.gap)
        if i < len(a.sessions):
            conn.close()
        else:
            while True:
                time.sleep(1)


if __name__ == "__main__":
    main()
