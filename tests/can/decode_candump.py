#!/usr/bin/python3
"""Decode a candump log (candump -L format) with a DBC file, independently of rutd's C++ code.

Usage: decode_candump.py DBC LOG

Decoding uses canmatrix's DBC loader and frame decoder. The end-to-end protection is checked here with
this script's own bitwise CRC-8/SAE-J1850 (poly 0x1D, init 0xFF, xor-out 0xFF) over the message's
E2E_DataID attribute (low byte, high byte) followed by payload bytes 1..7, compared with byte 0; the
rolling counter (signal *_Counter, 0..14) must advance by one per frame of a message, and a message
listed in SAME_COUNTER_AS must carry the counter of the frame it follows (at most once per leader
frame; the leader must be followed by every message in REQUIRED_PARTNERS before it comes again).

Prints CSV on stdout, one line per decoded signal:
    index,t_ns,message,signal,raw,phys,named,na
(index: 0-based line number of the frame in the log; named: the value-table text, if any; na: 1 when
a signal wider than one bit has all ones as raw value, the J1939 "not available" code). Problems go
to stderr, one line each, followed by a summary line
    frames=N crc_errors=N counter_errors=N unknown_frames=N bad_lines=N
Exit status 0 only if there were no problems; 2 if canmatrix is missing.
"""
import csv
import re
import sys

try:
    import canmatrix
    import canmatrix.formats
except ImportError:
    print("canmatrix is not installed for this interpreter", file=sys.stderr)
    sys.exit(2)

SAME_COUNTER_AS = {"RutMeasurement2": "RutMeasurement1", "RutConditions": "RutMeasurement1",
                   "RutMotion": "RutMeasurement1", "RutSegmentStats": "RutSegment"}
REQUIRED_PARTNERS = {"RutMeasurement1": {"RutMeasurement2"}, "RutSegment": {"RutSegmentStats"}}
COUNTER_MODULO = 15
LINE = re.compile(r"^\((\d+)\.(\d{6})\)\s+(\S+)\s+([0-9A-Fa-f]{3}|[0-9A-Fa-f]{8})#((?:[0-9A-Fa-f]{2})*)\s*$")


def crc8_sae_j1850(data):
    crc = 0xFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1D) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc ^ 0xFF


def read_log(path):
    """Yields (line_number, t_ns, id, extended, payload bytes) or (line_number, None, ...) for bad lines."""
    with open(path, encoding="ascii") as log:
        for number, line in enumerate(log):
            match = LINE.match(line)
            if not match:
                yield number, None, None, None, None
                continue
            seconds, micros, _, ident, data = match.groups()
            t_ns = int(seconds) * 10**9 + int(micros) * 1000
            yield number, t_ns, int(ident, 16), len(ident) == 8, bytes.fromhex(data)


def counter_signal(frame):
    names = [s.name for s in frame.signals if s.name.endswith("_Counter")]
    return names[0] if names else None


def check_counter(name, counter, last_counter, unpaired):
    """Returns what is wrong with this frame's counter, or an empty string. unpaired: leader name ->
    (its last counter, the followers seen since)."""
    if counter >= COUNTER_MODULO:
        return f"counter {counter} out of range"
    leader = SAME_COUNTER_AS.get(name)
    if leader is not None:
        if leader not in unpaired:
            return f"no {leader} frame before it"
        want, seen = unpaired[leader]
        if name in seen:
            return f"a second {name} after one {leader}"
        seen.add(name)
        return "" if counter == want else f"counter {counter}, its {leader} had {want}"
    error = ""
    if name in unpaired and not REQUIRED_PARTNERS.get(name, set()) <= unpaired[name][1]:
        error = f"the previous {name} was not followed by its partner"
    previous = last_counter.get(name)
    if previous is not None and counter != (previous + 1) % COUNTER_MODULO:
        error = f"counter {counter} after {previous}"
    last_counter[name] = counter
    if name in SAME_COUNTER_AS.values():
        unpaired[name] = (counter, set())
    return error


def main(dbc_path, log_path):
    db = canmatrix.formats.loadp_flat(dbc_path)
    out = csv.writer(sys.stdout, lineterminator="\n")
    out.writerow(["index", "t_ns", "message", "signal", "raw", "phys", "named", "na"])
    problems = []
    counts = {"frames": 0, "crc_errors": 0, "counter_errors": 0, "unknown_frames": 0, "bad_lines": 0}
    last_counter = {}  # message name -> its last counter
    unpaired = {}  # leader message name -> counter of its last frame not yet followed by its partner

    for index, t_ns, ident, extended, payload in read_log(log_path):
        if t_ns is None:
            counts["bad_lines"] += 1
            problems.append(f"BAD_LINE index={index}")
            continue
        counts["frames"] += 1
        frame = db.frame_by_id(canmatrix.ArbitrationId(id=ident, extended=extended))
        if frame is None or len(payload) != frame.size:
            counts["unknown_frames"] += 1
            problems.append(f"UNKNOWN_FRAME index={index} id={ident:X} len={len(payload)}")
            continue

        data_id = int(frame.attribute("E2E_DataID"))
        expected_crc = crc8_sae_j1850(bytes([data_id & 0xFF, data_id >> 8]) + payload[1:])
        if payload[0] != expected_crc:
            counts["crc_errors"] += 1
            problems.append(
                f"CRC_ERROR index={index} message={frame.name} got={payload[0]:02X} want={expected_crc:02X}")

        decoded = frame.decode(bytearray(payload))
        counter_name = counter_signal(frame)
        if counter_name is not None:
            error = check_counter(frame.name, decoded[counter_name].raw_value, last_counter, unpaired)
            if error:
                counts["counter_errors"] += 1
                problems.append(f"COUNTER_ERROR index={index} message={frame.name}: {error}")

        for signal in frame.signals:
            value = decoded[signal.name]
            named = value.named_value
            named = named if isinstance(named, str) else ""
            not_available = signal.size > 1 and value.raw_value == (1 << int(signal.size)) - 1
            out.writerow([index, t_ns, frame.name, signal.name, value.raw_value, value.phys_value, named,
                          int(not_available)])

    for problem in problems:
        print(problem, file=sys.stderr)
    print(" ".join(f"{k}={v}" for k, v in counts.items()), file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        sys.exit(64)
    sys.exit(main(sys.argv[1], sys.argv[2]))
