#!/usr/bin/python3
"""Frames with known speeds, encoded by canmatrix (independently of rutd's C++ code), for
test_vehicle_speed.cpp.

Usage: encode_speed_frames.py j1939 OUT           CCVS raw counts and ETC2 gears from canmatrix/j1939.dbc
       encode_speed_frames.py dbc DBC OUT SEED    random physical values of every signal of DBC's messages

Writes one line per frame: "candump-line;message;value", value the raw count (j1939) or the physical value
canmatrix encoded (dbc). Exit 2 if canmatrix is missing.
"""
import os
import random
import sys

try:
    import canmatrix.formats
except ImportError:
    print("canmatrix is not installed for this interpreter", file=sys.stderr)
    sys.exit(2)


def line(can_id, extended, data):
    ident = f"{can_id:08X}" if extended else f"{can_id:03X}"
    return f"(0000000000.000000) can0 {ident}#{bytes(data).hex().upper()}"


def j1939(out):
    db = canmatrix.formats.loadp_flat(os.path.join(os.path.dirname(canmatrix.__file__), "j1939.dbc"))
    ccvs, etc2 = db.frame_by_name("CCVS"), db.frame_by_name("ETC2")
    raws = [0, 1, 255, 256, 6400, 0xFAFF, 0xFB00, 0xFDFF, 0xFE00, 0xFEFF, 0xFF00, 0xFFFF]
    raws += random.Random(7).sample(range(0, 0xFAFF), 40)
    with open(out, "w") as f:
        for raw in raws:
            f.write(f"{line(0x18FEF100, True, ccvs.encode({'Wheel_Based_Vehicle_Speed': raw}))};CCVS;{raw}\n")
        for gear in [124, 125, 126, 251, 0xFE, 0xFF, 0]:
            f.write(f"{line(0x0CF00503, True, etc2.encode({'Transmission_Current_Gear': gear}))};ETC2;{gear}\n")


def dbc(path, out, seed):
    db = canmatrix.formats.loadp_flat(path)
    rng = random.Random(seed)
    with open(out, "w") as f:
        for frame in db.frames:
            for _ in range(50):
                values = {}
                for s in frame.signals:
                    # Any raw value; J1939's top ranges (not available, error, reserved) left out.
                    lo, hi = (-(1 << (s.size - 1)), (1 << (s.size - 1)) - 1) if s.is_signed else (0, (1 << s.size) - 1)
                    if frame.arbitration_id.extended:
                        hi = min(hi, (0xFB << (s.size - 8)) - 1)
                    values[s.name] = rng.randint(lo, hi)  # canmatrix's encode() takes raw values
                data = frame.encode(values)
                decoded = frame.decode(data)
                for s in frame.signals:
                    f.write(f"{line(frame.arbitration_id.id, frame.arbitration_id.extended, data)};{frame.name}.{s.name};"
                            f"{float(decoded[s.name].phys_value)!r}\n")


if __name__ == "__main__":
    if sys.argv[1] == "j1939":
        j1939(sys.argv[2])
    else:
        dbc(sys.argv[2], sys.argv[3], int(sys.argv[4]))
