#!/usr/bin/env python3
"""Checks `rutd map` output with readers rutd did not write: the GeoJSON through shapely (every geometry a
valid point, coordinates equal to positions of the drives' NMEA logs within their resolution, 1e-5 minute) and GDAL's ogrinfo (opens it as a
layer with the expected feature count and fields); matched.csv and the PNG's presence. Prints one JSON line of
figures for the test to assert on; exits 1 with a message on any failure.

Usage: check_map.py MAP_DIR TRUTH_CSV... (one truth per drive, in the map's drive order). Where a feature lies
along its drive comes from the truth it matches (speed x time since the drive's first epoch), not from the
map's own distances."""
import csv
import json
import subprocess
import sys

from shapely.geometry import shape


def main():
    out_dir, truths = sys.argv[1], sys.argv[2:]
    with open(f"{out_dir}/track.geojson") as f:
        doc = json.load(f)
    feats = doc["features"]
    drives = []  # per drive: (lon, lat, metres along the drive) of nmea_drive.py's truth, as written in the log
    for path in truths:
        with open(path) as f:
            rows = [r for r in csv.DictReader(f) if r["fix"] == "1"]
        t0 = float(rows[0]["utc_s"])
        drives.append([(float(r["lon_deg"]), float(r["lat_deg"]), (float(r["utc_s"]) - t0) * float(r["speed_m_s"]))
                       for r in rows])
    resolution = 1e-5 / 60.0
    for ft in feats:
        g = shape(ft["geometry"])
        if g.geom_type != "Point" or not g.is_valid:
            sys.exit(f"feature {ft['properties']} is not a valid point")
        d = ft["properties"]["drive"]
        along = [a for x, y, a in drives[d] if abs(g.x - x) <= resolution and abs(g.y - y) <= resolution]
        if not along:
            sys.exit(f"feature at {g.x},{g.y} is not a position of drive {d}'s log")
        ft["properties"]["truth_along_m"] = along[0]
        for key in ("mean_depth_mm", "pass", "advisory", "depth_uncertainty_mm", "horizontal_error_m", "piece_kind"):
            if key not in ft["properties"]:
                sys.exit(f"feature without {key}")
    info = subprocess.run(["ogrinfo", "-ro", "-al", "-so", f"{out_dir}/track.geojson"], capture_output=True,
                          text=True)
    if info.returncode != 0:
        sys.exit("ogrinfo cannot read it: " + info.stderr)
    count = [l for l in info.stdout.splitlines() if l.startswith("Feature Count:")]
    if not count or int(count[0].split(":")[1]) != len(feats):
        sys.exit("ogrinfo sees another feature count: " + info.stdout)
    for field in ("mean_depth_mm", "pass", "advisory", "sinkage_increase_mm"):
        if f"{field}:" not in info.stdout:
            sys.exit(f"ogrinfo sees no field {field}: " + info.stdout)
    with open(f"{out_dir}/matched.csv") as f:
        matched = list(csv.DictReader(f))
    inc = sorted(float(m["sinkage_increase_mm"]) for m in matched if m["sinkage_increase_mm"])
    by_drive = {}
    for ft in feats:
        p = ft["properties"]
        by_drive.setdefault(p["drive"], []).append(p)
    second = by_drive.get(1, [])
    props = [ft["properties"] for ft in feats]
    print(json.dumps({
        "features": len(feats),
        "segments": sum(1 for p in props if p["piece_kind"] == "segment"),
        "one_metre": sum(1 for p in props if abs(p["end_m"] - p["start_m"] - 1.0) < 1e-6),
        "advisory_known": sum(1 for p in props if p["advisory"] != "UNKNOWN"),
        # Pieces measured often enough for an advisory (trafficability.advisory.min_trusted_frames, 3): how many
        # depends on the frame rate (a sanitizer build measures a few pairs a second).
        "trusted": sum(1 for p in props if p["frames"] >= 3 and p["refused"] == 0),
        "trusted_advisory_known": sum(1 for p in props if p["frames"] >= 3 and p["refused"] == 0
                                      and p["advisory"] != "UNKNOWN"),
        "matched": len(matched),
        "median_increase_mm": inc[len(inc) // 2] if inc else None,
        "second_pass_before_turn": sum(1 for p in second if p["truth_along_m"] <= 7.0),
        "second_pass_before_turn_matched": sum(1 for p in second if p["truth_along_m"] <= 7.0 and p["pass"] == 1),
        "second_pass_after_turn": sum(1 for p in second if p["truth_along_m"] >= 10.0),
        "second_pass_after_turn_matched": sum(1 for p in second if p["truth_along_m"] >= 10.0 and p["pass"] > 0),
    }, separators=(",", ":")))


if __name__ == "__main__":
    main()
