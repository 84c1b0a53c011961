#!/usr/bin/python3
"""The status and condition bits of /api/live.json against the DBC, read by canmatrix (not ours): each
list must name, in bit order, exactly the one-bit signals of RutConditions and RutSensorStatus.

usage: check_bit_names.py URL DBC        prints one line per list; exit 1 on a difference"""
import json
import sys
import urllib.request

import canmatrix.formats

url, dbc = sys.argv[1], sys.argv[2]
live = json.load(urllib.request.urlopen(url, timeout=10))
db = next(iter(canmatrix.formats.loadp(dbc).values()))
failed = False
for key, message in (("conditions", "RutConditions"), ("health", "RutSensorStatus")):
    frame = db.frame_by_name(message)
    want = [s.name for s in sorted(frame.signals, key=lambda s: int(s.start_bit)) if int(s.size) == 1]
    got = [b["name"] for b in live[key]]
    same = got == want
    failed |= not same
    print("%s: %s against %s in the DBC: %s" % (key, got, message, "same" if same else "DIFFERENT: " + str(want)))
sys.exit(1 if failed else 0)
