#!/usr/bin/env python3
"""Checks `rutd bench --scenes --json` with Python's own JSON decoder: one object per scene, every
documented key with its type, and each scene's counts recomputed from its frames (OK within 1 mm of the
truth, OK beyond, refused, refused with an expected condition or status, refusals by status), each frame's error
against its own depth and truth, the water's truth present exactly in water scenes, and a water rule named
exactly on the frames flagged Water (an OK one read through the water); given the summary rutd printed
(stderr under --json), its scene x outcome table too: a row per kind of scene whose counts are the frames'.
Usage: check_scene_matrix_json.py FILE SCENES FRAMES [SUMMARY]. Prints what it checked; exits 1 naming the
first fault."""
import json
import math
import sys

SCENE_KEYS = {"scene": str, "group": str, "kind": str, "expect": list, "synth": str, "frames": int,
              "ok_within_1mm": int, "ok_beyond_1mm": int, "refused": int, "refused_within_1mm": int,
              "refused_with_expected": int,
              "refusals": dict, "worst_ok_error_mm": (int, float), "texture_to_noise": (int, float),
              "seconds": (int, float), "per_frame": list}
FRAME_KEYS = {"index": int, "status": str, "depth_mm": (int, float), "truth_mm": (int, float),
              "error_mm": (int, float), "uncertainty_mm": (int, float, type(None)), "conditions": list,
              "water_rule": (str, type(None)), "dry_overruled": (str, type(None)),
              "water_depth_mm": (int, float), "waterline_depth_mm": (int, float, type(None)),
              "exposure": (int, float), "gain": (int, float)}
# The rule that flagged a frame Water (MeasurementDiagnostics::water_rule), null on a frame not flagged.
WATER_RULES = {"lid", "lid_recalled", "lid_unlike_ground", "waterline_hides", "waterline_at_lid", "read_through",
               "candidate", "guard_strip", "frame_check"}
# The rules the steady dry frames before may overrule (StereoMeasurer::recall_dry).
DRY_OVERRULED = {"lid", "lid_recalled", "lid_unlike_ground", "waterline_hides", "candidate"}
CONDITIONS = {"Water", "LeftLensObstructed", "RightLensObstructed", "LowLight", "Overexposed", "Vegetation",
              "CalibrationDrift", "DepthUncertain"}


def typed(obj, keys, where):
    for key, kind in keys.items():
        if key not in obj or not isinstance(obj[key], kind) or (kind == int and isinstance(obj[key], bool)):
            return f"{where}: key {key} missing or not {kind}: {obj.get(key)!r}"
    return None


def check_scene(s, frames):
    name = s.get("scene", "?")
    fault = typed(s, SCENE_KEYS, name)
    if fault:
        return fault
    if s["group"] not in ("spoiled", "clean", "tread", "skew", "entry"):
        return f"{name}: group {s['group']}"
    if s["frames"] != frames or len(s["per_frame"]) != frames:
        return f"{name}: {s['frames']} frames, {len(s['per_frame'])} listed, want {frames}"
    within = beyond = refused = refused_within = expected = 0
    refusals = {}
    water = "--water-level" in s["synth"]
    pool = "--water-surface" in s["synth"]  # wet on the frames the rut reaches the pool's surface
    for i, f in enumerate(s["per_frame"]):
        fault = typed(f, FRAME_KEYS, f"{name} frame {i}")
        if fault:
            return fault
        if f["index"] != i or not set(f["conditions"]) <= CONDITIONS:
            return f"{name} frame {i}: index or conditions {f}"
        if ("Water" in f["conditions"]) != (f["water_rule"] is not None) or \
                (f["water_rule"] is not None and f["water_rule"] not in WATER_RULES):
            return f"{name} frame {i}: water rule {f['water_rule']!r} with conditions {f['conditions']}"
        # A rule judging the strip's looks, overruled by the steady dry frames before: the frame is not flagged.
        if f["dry_overruled"] is not None and (f["dry_overruled"] not in DRY_OVERRULED or f["water_rule"] is not None):
            return f"{name} frame {i}: dry_overruled {f['dry_overruled']!r} with water rule {f['water_rule']!r}"
        # A depth published with the Water flag is one read through the water; every other rule refuses.
        if f["status"] == "OK" and f["water_rule"] not in (None, "read_through"):
            return f"{name} frame {i}: published OK by water rule {f['water_rule']}"
        if abs(f["error_mm"] - (f["depth_mm"] - f["truth_mm"])) > 2e-4:
            return f"{name} frame {i}: error {f['error_mm']} is not depth - truth"
        wet = f["water_depth_mm"] > 0
        if (wet != (f["waterline_depth_mm"] is not None)) or (not pool and water != wet):
            return f"{name} frame {i}: water truth {f['water_depth_mm']}, {f['waterline_depth_mm']}"
        if f["gain"] < 1 or f["exposure"] <= 0:
            return f"{name} frame {i}: exposure {f['exposure']} gain {f['gain']}"
        if f["status"] == "OK":
            if abs(f["error_mm"]) <= 1.0:
                within += 1
            else:
                beyond += 1
        else:
            refused += 1
            refused_within += abs(f["error_mm"]) <= 1.0
            refusals[f["status"]] = refusals.get(f["status"], 0) + 1
            # An expected condition, or an expected status (UNSYNCHRONISED has no condition bit).
            expected += bool(set(f["conditions"]) & set(s["expect"])) or f["status"] in s["expect"]
    got = (s["ok_within_1mm"], s["ok_beyond_1mm"], s["refused"], s["refused_within_1mm"], s["refused_with_expected"],
           s["refusals"])
    want = (within, beyond, refused, refused_within, expected, refusals)
    if got != want:
        return f"{name}: counts {got}, frames say {want}"
    return None


def kind_rows(summary):
    """The scene x outcome table's rows: kind -> (group, scenes, ok<=1, ok>1, refused, ref<=1, right flag)."""
    rows = {}
    head = summary.find("\nkind ")
    if head < 0:
        return rows
    for line in summary[head + 1:].split("\n")[1:]:
        cols = line.split()
        if len(cols) < 9:
            break
        rows[cols[0]] = (cols[1], int(cols[2]), int(cols[3]), int(cols[4]), int(cols[6]), int(cols[7]), cols[8])
    return rows


def check_kinds(objs, summary):
    """Each kind's row recomputed from its scenes' frames, and a row for every kind and no other."""
    want = {}
    for s in objs:
        g, n, within, beyond, refused, ref_within, expected, flagged = want.get(s["kind"], (s["group"], 0, 0, 0, 0, 0, 0, bool(s["expect"])))
        for f in s["per_frame"]:
            ok = f["status"] == "OK"
            within += ok and abs(f["error_mm"]) <= 1.0
            beyond += ok and abs(f["error_mm"]) > 1.0
            refused += not ok
            ref_within += not ok and abs(f["error_mm"]) <= 1.0
            expected += not ok and (bool(set(f["conditions"]) & set(s["expect"])) or f["status"] in s["expect"])
        want[s["kind"]] = (g, n + 1, within, beyond, refused, ref_within, expected, flagged)
    got = kind_rows(summary)
    if set(got) != set(want):
        return f"kind table rows {sorted(got)}, scenes' kinds {sorted(want)}"
    for kind, (g, n, within, beyond, refused, ref_within, expected, flagged) in want.items():
        right = f"{expected}/{refused}" if flagged else "-"
        if got[kind] != (g, n, within, beyond, refused, ref_within, right):
            return f"kind {kind}: row {got[kind]}, frames say {(g, n, within, beyond, refused, ref_within, right)}"
    return None


def main() -> int:
    path, scenes, frames = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    with open(path, encoding="utf-8") as f:
        lines = [line for line in f.read().split("\n") if line]
    if len(lines) != scenes:
        print(f"{len(lines)} JSON lines, want {scenes}")
        return 1
    objs = [json.loads(line) for line in lines]
    for obj in objs:
        fault = check_scene(obj, frames)
        if fault:
            print(fault)
            return 1
    checked = ""
    if len(sys.argv) > 4:
        with open(sys.argv[4], encoding="utf-8") as f:
            fault = check_kinds(objs, f.read())
        if fault:
            print(fault)
            return 1
        checked = f"; the kind table's {len(set(o['kind'] for o in objs))} rows too"
    print(f"{scenes} scenes x {frames} frames: keys, types and counts agree with the frames{checked}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
