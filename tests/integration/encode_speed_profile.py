#!/usr/bin/python3
"""Writes a candump log of J1939 CCVS frames (wheel-based vehicle speed) encoded by canmatrix from its own
J1939 database (canmatrix/j1939.dbc), for a speed profile: a vehicle as rutd would hear it on the bus.

Usage: encode_speed_profile.py OUT RATE_HZ DURATION_S T_S:KMH,... [GAP_FROM_S:GAP_TO_S,...] [gear]
  linear between knots; no frames inside the gaps (the sender falls silent). A negative speed is
  reversing: CCVS carries its magnitude, and with `gear` an ETC2 frame (Transmission_Current_Gear,
  identifier 0CF00503: priority 3, the transmission's address 0x03) goes before every fifth speed frame
  with gear -1 while reversing, +1 while driving forward (either as engaged 0.1 s before the wheels
  turn), the last gear while standing. Identifier 18FEF100
  (priority 6, source address 0x00). Exit 2 if canmatrix is missing.
"""
import os
import sys

try:
    import canmatrix.formats
except ImportError:
    print("canmatrix is not installed for this interpreter", file=sys.stderr)
    sys.exit(2)


def main(out, rate, duration, profile, gap, with_gear):
    db = canmatrix.formats.loadp_flat(os.path.join(os.path.dirname(canmatrix.__file__), "j1939.dbc"))
    ccvs, etc2 = db.frame_by_name("CCVS"), db.frame_by_name("ETC2")
    gear = 1
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
            v = speed(t)
            us = round(t * 1e6)
            stamp = f"({us // 10**6:010d}.{us % 10**6:06d}) can0"
            if with_gear and i % 5 == 0:
                # The driver engages the gear before the wheels turn: the sign of the speed 0.1 s ahead.
                ahead = speed(t + 0.1) or v
                gear = -1 if ahead < 0 else 1 if ahead > 0 else gear
                data = etc2.encode({"Transmission_Current_Gear": gear + 125})  # raw: offset -125
                log.write(f"{stamp} 0CF00503#{bytes(data).hex().upper()}\n")
            # canmatrix's encode() takes raw values: 1/256 km/h counts.
            data = ccvs.encode({"Wheel_Based_Vehicle_Speed": round(abs(v) * 256)})
            log.write(f"{stamp} 18FEF100#{bytes(data).hex().upper()}\n")


if __name__ == "__main__":
    args = sys.argv[1:]
    gear_mode = args[-1] == "gear"
    if gear_mode:
        args = args[:-1]
    main(args[0], float(args[1]), float(args[2]), args[3], args[4] if len(args) > 4 else "", gear_mode)
