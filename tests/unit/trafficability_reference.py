#!/usr/bin/env python3
"""Independent reference of trafficability/ (docs/DESIGN.md, the definitions in
trafficability/include/trafficability/*.hpp), written from those definitions in plain Python, for
test_trafficability.cpp. Reads speed.csv (t_ns,state,speed_mm_s) and frames.csv
(t_ns,status,depth_mm,width_mm,area_mm2,u_mm), config.csv (key,value), writes segments_ref.csv,
damage_ref.csv and motion_ref.csv (per frame: t_ns, distance_m, empty while the speed is unknown) to the
folder given.

Usage: trafficability_reference.py FOLDER
"""
import csv
import math
import statistics
import sys

OK, NO_RUT = 0, 1
SEVERITY = [0, 1, 6, 7, 5, 11, 10, 8, 9, 4, 3, 2]
GO, CAUTION, NO_GO, UNKNOWN = 1, 2, 3, 0


def motions(speed, frames, max_age_ns):
    """Distance (m) of new ground at each frame, or None: the motion from the samples received up to
    the frame's time."""
    out = []
    si = 0
    pos = 0.0          # mm, signed
    far = 0.0          # mm, furthest
    last = None        # (t, ok, v) of the last sample fed
    for f in frames:
        t = f["t_ns"]
        while si < len(speed) and speed[si][0] <= t:
            ts, state, v = speed[si]
            si += 1
            if last is not None and ts < last[0]:
                continue
            ok = state == 0 and math.isfinite(v)
            if ok and last is not None and last[1] and ts - last[0] <= max_age_ns:
                pos += (last[2] + v) / 2 * (ts - last[0]) / 1e9
                far = max(far, pos)
            last = (ts, ok, v if ok else 0.0)
        if last is None or not last[1] or t - last[0] > max_age_ns:
            out.append(None)
            continue
        out.append(far / 1000)  # the furthest point at the last sample: not extrapolated
    return out


def interp(table, z, u):
    zs = [p[0] for p in table]
    ss = [p[1] for p in table]
    if z <= zs[0]:
        i = 0
    elif z >= zs[-1]:
        i = len(zs) - 2
    else:
        i = max(j for j in range(len(zs) - 1) if zs[j] < z) if z > zs[0] else 0
    slope = (ss[i + 1] - ss[i]) / (zs[i + 1] - zs[i])
    if z <= zs[0]:
        value = ss[0]
    elif z >= zs[-1]:
        value = ss[-1]
    else:
        value = ss[i] + slope * (z - zs[i])
    return value, abs(slope) * u


def main(folder):
    cfg = {r[0]: r[1] for r in csv.reader(open(f"{folder}/config.csv"))}
    length = float(cfg["length_m"])
    max_age = int(cfg["max_age_ns"])
    caution, no_go = float(cfg["caution_depth_mm"]), float(cfg["no_go_depth_mm"])
    hyst = float(cfg["hysteresis_m"])
    max_untrusted = float(cfg["max_untrusted_fraction"])
    min_trusted = int(cfg["min_trusted_frames"])
    k = float(cfg["coverage_factor"])
    table = [tuple(map(float, p.split(":"))) for p in cfg["soil_table"].split()]
    one, fifty = float(cfg["limit_one_pass"]), float(cfg["limit_fifty_passes"])
    rules = [tuple(map(float, r.split(":"))) for r in cfg["damage"].split()]

    speed = [(int(r["t_ns"]), int(r["state"]), float(r["speed_mm_s"])) for r in csv.DictReader(open(f"{folder}/speed.csv"))]
    frames = [dict(t_ns=int(r["t_ns"]), status=int(r["status"]), depth=float(r["depth_mm"]), width=float(r["width_mm"]),
                   area=float(r["area_mm2"]), u=float(r["u_mm"])) for r in csv.DictReader(open(f"{folder}/frames.csv"))]
    dist = motions(speed, frames, max_age)

    # Placement: strictly beyond the last placed distance.
    segs = {}      # index -> list of frames placed
    untrusted = set()
    placed = []    # (d, frame)
    current = None
    for f, d in zip(frames, dist):
        if d is None:
            if current is not None:
                untrusted.add(current)
            continue
        if placed and d <= placed[-1][0]:
            continue
        kk = int(math.floor(d / length))
        current = kk
        segs.setdefault(kk, []).append(f)
        placed.append((d, f))

    rows = []
    first, last = min(segs), max(segs)
    recent = []
    for idx in range(first, last + 1):
        fs = segs.get(idx, [])
        oks = [f for f in fs if f["status"] == OK]
        norut = sum(1 for f in fs if f["status"] == NO_RUT)
        row = dict(index=idx, start_m=idx * length, end_m=(idx + 1) * length, frames=len(fs),
                   refused=len(fs) - len(oks))
        depths = [f["depth"] for f in oks]
        if oks:
            row["mean"] = statistics.fmean(depths)
            row["max"] = max(depths)
            row["p95"] = statistics.quantiles(depths, n=20, method="inclusive")[18] if len(depths) > 1 else depths[0]
            row["width"] = statistics.fmean(f["width"] for f in oks)
            row["area"] = statistics.fmean(f["area"] for f in oks)
            us = [f["u"] for f in oks if math.isfinite(f["u"])]
            row["u"] = statistics.fmean(us) if us else math.nan
            s, su = interp(table, row["mean"], row["u"] if us else 0.0)
            row["strength"], row["strength_u"] = s, su
        else:
            for key in ("mean", "max", "p95", "width", "area", "u", "strength", "strength_u"):
                row[key] = math.nan
        row["worst"] = max((f["status"] for f in fs), key=lambda st: SEVERITY[st]) if fs else 5
        trusted = len(oks) + norut
        if idx in untrusted or trusted < min_trusted or not fs or (len(fs) - trusted) / len(fs) > max_untrusted:
            raw = UNKNOWN
        else:
            rank = {GO: 0, CAUTION: 1, NO_GO: 2}
            level = GO
            if oks:
                level = NO_GO if row["p95"] >= no_go else CAUTION if row["p95"] >= caution else GO
                lo, hi = row["strength"] - k * row["strength_u"], row["strength"] + k * row["strength_u"]
                by = NO_GO if hi < one else CAUTION if (lo < one or lo < fifty) else GO
                level = level if rank[level] >= rank[by] else by
            raw = level
        if raw == UNKNOWN:
            adv = UNKNOWN
        else:
            rank = {GO: 0, CAUTION: 1, NO_GO: 2, UNKNOWN: 1}
            window = [a for (end, a) in recent if end > row["start_m"] - hyst + 1e-9] + [raw]
            adv = max(window, key=lambda a: rank[a])
            adv = CAUTION if adv == UNKNOWN else adv
        recent.append((row["end_m"], raw))
        row["advisory"] = adv
        rows.append(row)

    with open(f"{folder}/segments_ref.csv", "w") as out:
        keys = ["index", "start_m", "end_m", "frames", "refused", "mean", "max", "p95", "width", "area", "u", "strength",
                "strength_u", "worst", "advisory"]
        out.write(",".join(keys) + "\n")
        for r in rows:
            out.write(",".join(repr(r[key]) for key in keys) + "\n")

    with open(f"{folder}/motion_ref.csv", "w") as out:
        out.write("t_ns,distance_m\n")
        for f, d in zip(frames, dist):
            out.write(f"{f['t_ns']},{'' if d is None else repr(d)}\n")

    with open(f"{folder}/damage_ref.csv", "w") as out:
        out.write("rule,rutted_m,measured_m,unmeasured_m,stretches\n")
        for i, (depth, min_len) in enumerate(rules):
            rutted = measured = unmeasured = 0.0
            stretches = 0
            run = 0.0
            for (d0, f), (d1, _) in zip(placed, placed[1:]):
                c = d1 - d0
                if f["status"] in (OK, NO_RUT):
                    measured += c
                else:
                    unmeasured += c
                if f["status"] == OK and f["depth"] > depth:
                    run += c
                else:
                    if run >= min_len:
                        rutted += run
                        stretches += 1
                    run = 0.0
            if run >= min_len:
                rutted += run
                stretches += 1
            out.write(f"{i},{rutted!r},{measured!r},{unmeasured!r},{stretches}\n")


if __name__ == "__main__":
    main(sys.argv[1])
