#!/usr/bin/python3
"""Writes a candump log of J1939 CCVS frames (wheel-based vehicle speed) encoded by canmatrix from its own
J1939 database (canmatrix/j1939.dbc), for a speed profile: a vehicle as rutd would hear it on the bus.

Usage: encode_speed_profile.py OUT RATE_HZ DURATION_S T_S:KMH,... [GAP_FROM_S:GAP_TO_S,...]
  linear between knots; no frames inside the gaps (the sender falls silent). Identifier 18FEF100
  (priority 6, source address 0x00). Exit 2 if canmatrix is missing.
"""
import os
import sys

try:
    import canmatrix.formats
except ImportError:
    print("canmatrix is not installed for this interpreter", file=sys.stderr)
    sys.exit(2)


def main(out, rate, duration, profile, gap):
    db = canmatrix.formats.loadp_flat(os.path.join(os.path.dirname(canmatrix.__file__), "j1939.dbc"))
    ccvs = db.frame_by_name("CCVS")
    knots = [tuple(map(float, k.split(":"))) for k in profile.split(",")]
    gaps = [tuple(map(float, g.split(":"))) for g in gap.split(",")] if gap else []

    def speed(t):
        if t <= knots[0][0]:
            return knots[0][1]
        for (t0, v0), (t1, v1) in zip(knots, knots[1:]):
            if t <= t1:
                return v0 + (v1 - v0) * (t - t0) / (t1 - t0)
        return knots[-1][1]

    with open(out, "w") as log:
        for i in range(int(duration * rate) + 1):
            t = i / rate
            if any(a <= t < b for a, b in gaps):
                continue
            # canmatrix's encode() takes raw values: 1/256 km/h counts.
            data = ccvs.encode({"Wheel_Based_Vehicle_Speed": round(speed(t) * 256)})
            us = round(t * 1e6)
            log.write(f"({us // 10**6:010d}.{us % 10**6:06d}) can0 18FEF100#{bytes(data).hex().upper()}\n")


if __name__ == "__main__":
    main(sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), sys.argv[4], sys.argv[5] if len(sys.argv) > 5 else "")
