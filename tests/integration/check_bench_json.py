#!/usr/bin/env python3
"""Checks `rutd bench --json` output with Python's own JSON decoder: one object per line, the four runs
(strip/full x throughput/live), every documented key with its type, and the strip runs' worst depth error
against the renderer's truth within MAX_ERR_MM. Prints what it checked; exits 1 naming the first fault."""
import json
import sys

MAX_ERR_MM = float(sys.argv[2]) if len(sys.argv) > 2 else 0.5
KEYS = {"mode": str, "run": str, "engine": str, "dic": bool, "width": int, "height": int, "rows": int,
        "hz": (int, float), "p50_ms": (int, float), "p99_ms": (int, float), "depth_err_mm": (int, float, type(None)),
        "device": str}


def main() -> int:
    with open(sys.argv[1], encoding="utf-8") as f:
        lines = [line for line in f.read().split("\n") if line]
    runs = [json.loads(line) for line in lines]
    seen = sorted((r["mode"], r["run"]) for r in runs)
    want = sorted((m, r) for m in ("strip", "full") for r in ("throughput", "live"))
    if seen != want:
        print(f"runs {seen}, want {want}")
        return 1
    for r in runs:
        for key, kind in KEYS.items():
            if key not in r or not isinstance(r[key], kind) or (kind == int and isinstance(r[key], bool)):
                print(f"{r.get('mode')}/{r.get('run')}: key {key} missing or not {kind}: {r.get(key)!r}")
                return 1
        if r["hz"] < 0 or r["p99_ms"] < r["p50_ms"] or r["width"] != 640 or r["height"] != 480:
            print(f"{r['mode']}/{r['run']}: implausible figures {r}")
            return 1
        # A full frame can take longer than a short run on a loaded machine: only the strip must publish.
        if r["mode"] == "strip" and r["hz"] <= 0:
            print(f"strip/{r['run']}: nothing published {r}")
            return 1
        if r["mode"] == "strip":
            if r["depth_err_mm"] is None or r["depth_err_mm"] > MAX_ERR_MM:
                print(f"strip/{r['run']}: worst depth error {r['depth_err_mm']} mm, limit {MAX_ERR_MM} mm")
                return 1
        elif r["rows"] != 480:
            print(f"full/{r['run']}: {r['rows']} rows measured, want 480")
            return 1
    print(f"{len(runs)} runs checked; strip worst depth errors "
          f"{[r['depth_err_mm'] for r in runs if r['mode'] == 'strip']} mm")
    return 0


if __name__ == "__main__":
    sys.exit(main())
