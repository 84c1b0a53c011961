#!/usr/bin/env python3
"""Checks `rutd map` output with readers rutd did not write: the GeoJSON through shapely (every geometry a
valid point, coordinates equal to positions of the drives' NMEA logs within their resolution, 1e-5 minute) and GDAL's ogrinfo (opens it as a
layer with the expected feature count and fields); matched.csv and the PNG's presence. Prints one JSON line of
figures for the test to assert on; exits 1 with a message on any failure."""
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
    positions = []
    for path in truths:  # nmea_drive.py's truth: the positions as written in the log
        with open(path) as f:
            for row in csv.DictReader(f):
                if row["fix"] == "1":
                    positions.append((float(row["lon_deg"]), float(row["lat_deg"])))
    resolution = 1e-5 / 60.0
    for ft in feats:
        g = shape(ft["geometry"])
        if g.geom_type != "Point" or not g.is_valid:
            sys.exit(f"feature {ft['properties']} is not a valid point")
        if not any(abs(g.x - x) <= resolution and abs(g.y - y) <= resolution for x, y in positions):
            sys.exit(f"feature at {g.x},{g.y} is not a position of the logs")
        for key in ("mean_depth_mm", "pass", "advisory", "depth_uncertainty_mm", "horizontal_error_m"):
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
    print(json.dumps({
        "features": len(feats),
        "matched": len(matched),
        "median_increase_mm": inc[len(inc) // 2] if inc else None,
        "second_pass_before_turn": sum(1 for p in second if p["end_m"] <= 7.0),
        "second_pass_before_turn_matched": sum(1 for p in second if p["end_m"] <= 7.0 and p["pass"] == 1),
        "second_pass_after_turn": sum(1 for p in second if p["start_m"] >= 10.0),
        "second_pass_after_turn_matched": sum(1 for p in second if p["start_m"] >= 10.0 and p["pass"] > 0),
    }, separators=(",", ":")))


if __name__ == "__main__":
    main()
