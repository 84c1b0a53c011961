#!/usr/bin/python3
"""Checks what subscribe.py received against docs/uplink.schema.json (python3-jsonschema, Draft 2020-12)
and says, as one JSON line, what a fleet consumer would see per vehicle: messages, how many are invalid
(and the first reasons), the queued messages' ids (distinct, the highest, the ids missing below it),
duplicates (a repeated id) and whether every copy of an id carried the same payload, whether the arrival
order is a merge of at most two increasing runs of ids (the uplink's live and backlog lanes: the longest
decreasing subsequence of first arrivals is at most 2), and the status messages seen.

Usage: check_messages.py SCHEMA RECEIVED_JSONL
"""
import bisect
import json
import sys

import jsonschema


def longest_decreasing(ids):
    tails = []  # patience sorting on the negated sequence
    for x in ids:
        i = bisect.bisect_left(tails, -x)
        if i == len(tails):
            tails.append(-x)
        else:
            tails[i] = -x
    return len(tails)


def main(schema_path, received_path):
    schema = json.load(open(schema_path))
    validator = jsonschema.Draft202012Validator(schema)
    per_vehicle = {}
    for line in open(received_path):
        m = json.loads(line)
        vehicle = m["topic"].split("/")[1] if m["topic"].count("/") >= 2 else "?"
        v = per_vehicle.setdefault(vehicle, {"messages": 0, "invalid": 0, "reasons": [], "arrivals": [],
                                             "payloads": {}, "types": {}, "status": []})
        v["messages"] += 1
        p = m["payload"]
        errors = [e.message[:160] for e in validator.iter_errors(p)] if isinstance(p, dict) else ["not JSON"]
        if errors:
            v["invalid"] += 1
            v["reasons"] += errors[:2]
            continue
        if not m["topic"].endswith("/" + p["type"]):
            v["invalid"] += 1
            v["reasons"].append(f"type {p['type']} on {m['topic']}")
        v["types"][p["type"]] = v["types"].get(p["type"], 0) + 1
        if p["type"] == "status":
            v["status"].append(p["state"] + (" (retained)" if m["retain"] else ""))
            continue
        text = json.dumps(p, sort_keys=True)
        copies = v["payloads"].setdefault(p["id"], [])
        if not copies:
            v["arrivals"].append(p["id"])
        copies.append(text)
    report = {}
    for vehicle, v in per_vehicle.items():
        ids = sorted(v["payloads"])
        top = ids[-1] if ids else 0
        report[vehicle] = {
            "messages": v["messages"], "invalid": v["invalid"], "reasons": v["reasons"][:4],
            "distinct_ids": len(ids), "first_id": ids[0] if ids else 0, "highest_id": top,
            "missing": len(set(range(ids[0] if ids else 1, top + 1)) - set(ids)),
            "duplicates": sum(len(c) - 1 for c in v["payloads"].values()),
            "duplicates_differ": sum(1 for c in v["payloads"].values() if len(set(c)) > 1),
            "decreasing": longest_decreasing(v["arrivals"]), "types": v["types"], "status": v["status"],
        }
    print(json.dumps(report, separators=(",", ":")))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
