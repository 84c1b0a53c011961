#!/usr/bin/python3
"""The inputs of tests/unit/trafficability_reference.py from a replayed recording, independently of rutd's
C++ code: vehicle.log decoded by canmatrix with its own J1939 database (canmatrix/j1939.dbc: CCVS
Wheel_Based_Vehicle_Speed, ETC2 Transmission_Current_Gear) into WORK/speed.csv, and the per-frame
measurement CSV into WORK/frames.csv. The speed's sender is address 0x00 (others are ignored as spoofed).

Usage: segments_from_recording.py RECORDING MEASUREMENT_CSV WORK [gear]
  gear: the direction comes from ETC2 (trafficability.speed.direction_from_gear: true)
Exit 2 if canmatrix is missing.
"""
import csv
import os
import re
import sys

try:
    import canmatrix.formats
except ImportError:
    print("canmatrix is not installed for this interpreter", file=sys.stderr)
    sys.exit(2)

STATUS = ["OK", "NO_RUT", "TOO_FEW_POINTS", "NO_GROUND", "RUT_AT_EDGE", "NO_MEASUREMENT", "LENS_OBSTRUCTED",
          "BAD_EXPOSURE", "CALIBRATION_DRIFT", "BOTTOM_NOT_SEEN", "VEGETATION", "UNCERTAIN", "UNSYNCHRONISED"]
LINE = re.compile(r"^\((\d+)\.(\d{6})\)\s+\S+\s+([0-9A-Fa-f]{8})#([0-9A-Fa-f]*)\s*$")


def main(recording, measurements, work, gear_mode):
    dbc_path = os.path.join(os.path.dirname(canmatrix.__file__), "j1939.dbc")
    db = canmatrix.formats.loadp_flat(dbc_path)
    ccvs, etc2 = db.frame_by_name("CCVS"), db.frame_by_name("ETC2")
    speed = []
    gear = None
    last_accepted = None  # trafficability.speed.min_interval_ms (5): closer frames are a burst, ignored
    last_value = None  # (t_ns, mm/s) of the last speed value, for the plausibility of the next
    for line in open(os.path.join(recording, "vehicle.log")):
        m = LINE.match(line)
        t_ns = int(m.group(1)) * 10**9 + int(m.group(2)) * 1000
        can_id = int(m.group(3), 16)
        data = bytearray.fromhex(m.group(4))
        pgn = (can_id >> 8) & 0x3FFFF
        if pgn == 0xFEF1 and can_id & 0xFF != 0:  # trafficability.speed.source_address: 0 in the test
            continue
        if pgn == 0xF005:
            raw = int(etc2.decode(data)["Transmission_Current_Gear"].raw_value)
            gear = None if raw > 251 else (-1 if raw < 125 else 1 if 125 < raw <= 250 else 0)
            continue
        if pgn != 0xFEF1 or len(data) < 3:  # the speed needs bytes 1..2
            continue
        if last_accepted is not None and t_ns - last_accepted < 5_000_000:
            continue
        last_accepted = t_ns
        raw = int(ccvs.decode(data)["Wheel_Based_Vehicle_Speed"].raw_value)
        if raw >= 0xFB00:  # reserved, error, not available (J1939-71)
            speed.append((t_ns, 1, 0.0))
            continue
        mm_s = raw / 256 / 3.6 * 1000
        # trafficability.speed.max_accel_m_s2 (15): a faster change from the previous value is implausible,
        # an error sample (frames bunched by a loaded sender's timing make such changes).
        jump = last_value is not None and t_ns > last_value[0] and \
            abs(mm_s - last_value[1]) > 15000 * (t_ns - last_value[0]) / 1e9
        last_value = (t_ns, mm_s)
        if jump:
            speed.append((t_ns, 1, 0.0))
            continue
        if gear_mode and mm_s != 0:
            if not gear:
                speed.append((t_ns, 1, 0.0))
                continue
            mm_s *= gear
        speed.append((t_ns, 0, mm_s))
    with open(os.path.join(work, "speed.csv"), "w") as out:
        out.write("t_ns,state,speed_mm_s\n")
        for t, state, v in speed:
            out.write(f"{t},{state},{v!r}\n")
    with open(os.path.join(work, "frames.csv"), "w") as out:
        out.write("t_ns,status,depth_mm,width_mm,area_mm2,u_mm\n")
        for r in csv.DictReader(open(measurements)):
            out.write(f"{r['t_ns']},{STATUS.index(r['status'])},{r['rut_depth_mm'] or 'nan'},{r['rut_width_mm'] or 'nan'},"
                      f"{r['area_mm2'] or 'nan'},nan\n")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3], len(sys.argv) > 4 and sys.argv[4] == "gear")
