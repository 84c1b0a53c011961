#!/usr/bin/python3
"""Makes an uplink queue as a long time out of radio range leaves it: N health messages of VEHICLE, ids 1..N,
in the queue's own SQLite format (drivers/uplink/outbox.cpp's table), so that a test can kill rutd while it
drains a backlog that takes seconds rather than milliseconds. The payloads follow docs/uplink.schema.json.

Usage: prefill_queue.py QUEUE_FILE N VEHICLE
"""
import json
import sqlite3
import sys
import time


def main(path, n, vehicle):
    db = sqlite3.connect(path)
    db.execute("PRAGMA journal_mode=WAL")
    db.execute("CREATE TABLE IF NOT EXISTS outbox(id INTEGER PRIMARY KEY AUTOINCREMENT, topic TEXT NOT NULL,"
               " payload TEXT NOT NULL, created_unix_ns INTEGER NOT NULL)")
    now = time.time_ns() - n * 10**9
    sensor = {"no_camera": False, "stale_frames": False, "calibration_invalid": False, "low_texture": False,
              "frame_drops": False, "can_tx_drops": False, "bus_off": False, "recording_error": False,
              "frame_rate_hz": 30.0, "dropped_frames": 0, "last_status": "OK"}
    rows = []
    for i in range(1, n + 1):
        t = now + i * 10**9
        created = time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(t // 10**9)) + f".{(t // 10**6) % 1000:03d}Z"
        uplink = {"link": "down", "queued": i, "queued_bytes": 0, "oldest_unsent_s": float(i), "sent": 0,
                  "acknowledged": 0, "send_errors": 0, "connect_failures": i, "dropped_oldest": 0, "queue_errors": 0,
                  "not_queued": 0}
        payload = {"id": i, "schema": "rutd-uplink/1", "type": "health", "vehicle": vehicle, "created": created,
                   "sensor": sensor, "uplink": uplink}
        rows.append(("health", json.dumps(payload, separators=(",", ":")), t))
    db.executemany("INSERT INTO outbox(topic, payload, created_unix_ns) VALUES(?, ?, ?)", rows)
    db.commit()
    db.close()


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), sys.argv[3])
