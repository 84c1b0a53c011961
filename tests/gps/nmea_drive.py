#!/usr/bin/env python3
"""Writes NMEA 0183 logs of a drive for the gpsd tests: GGA (position, fix quality, HDOP, altitude) and RMC
(position, speed, track, date) per epoch, as a receiver sends them, and a CSV of the exact positions written
(rounded to the log's resolution: 1e-5 minute of arc, about 2 cm).

A pass drives a straight line from an origin along a heading at a constant speed, one epoch per
`--period` seconds. `--offset-north-m`/`--offset-east-m` shift the whole track (a second pass beside the
first) and `--noise-m` adds Gaussian noise (seeded) to every position, as a receiver's error does.
`--diverge-after-m` turns the track by `--diverge-deg` after that distance (a stretch not in common).
"""
import argparse
import csv
import math
import random

EARTH_R = 6378137.0  # WGS84 semi-major axis, m: local metres to degrees


def checksum(body):
    c = 0
    for ch in body:
        c ^= ord(ch)
    return f"{c:02X}"


def sentence(body):
    return f"${body}*{checksum(body)}\r\n"


def nmea_angle(value, deg_digits):
    hemi = value >= 0
    value = abs(value)
    deg = int(value)
    minutes = round((value - deg) * 60.0, 5)
    if minutes >= 60.0:
        deg, minutes = deg + 1, 0.0
    return f"{deg:0{deg_digits}d}{minutes:08.5f}", hemi


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--out", required=True)
    p.add_argument("--truth", required=True)
    p.add_argument("--lat", type=float, default=-25.7545)
    p.add_argument("--lon", type=float, default=28.2314)
    p.add_argument("--alt", type=float, default=1340.0)
    p.add_argument("--heading-deg", type=float, default=60.0)
    p.add_argument("--speed", type=float, default=2.0, help="m/s")
    p.add_argument("--period", type=float, default=0.2, help="s per epoch")
    p.add_argument("--epochs", type=int, default=50)
    p.add_argument("--offset-north-m", type=float, default=0.0)
    p.add_argument("--offset-east-m", type=float, default=0.0)
    p.add_argument("--noise-m", type=float, default=0.0)
    p.add_argument("--diverge-after-m", type=float, default=-1.0)
    p.add_argument("--diverge-deg", type=float, default=60.0)
    p.add_argument("--hdop", type=float, default=0.8)
    p.add_argument("--no-fix-epochs", type=int, default=0, help="epochs without a fix at the start")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--start", type=float, default=43200.0, help="UTC seconds of day of the first epoch")
    a = p.parse_args()
    rng = random.Random(a.seed)
    north, east = a.offset_north_m, a.offset_east_m
    heading = a.heading_deg
    travelled = 0.0
    with open(a.out, "w", newline="") as out, open(a.truth, "w", newline="") as truth_file:
        truth = csv.writer(truth_file)
        truth.writerow(["epoch", "utc_s", "fix", "lat_deg", "lon_deg", "alt_m", "track_deg", "speed_m_s"])
        for i in range(a.epochs):
            t = a.start + i * a.period
            hh, rem = divmod(t, 3600)
            mm, ss = divmod(rem, 60)
            stamp = f"{int(hh):02d}{int(mm):02d}{ss:05.2f}"
            fix = i >= a.no_fix_epochs
            n = north + rng.gauss(0.0, a.noise_m)
            e = east + rng.gauss(0.0, a.noise_m)
            lat = a.lat + math.degrees(n / EARTH_R)
            lon = a.lon + math.degrees(e / (EARTH_R * math.cos(math.radians(a.lat))))
            lat_text, lat_n = nmea_angle(lat, 2)
            lon_text, lon_e = nmea_angle(lon, 3)
            # The position as written, read back: what a decoder must report.
            lat_w = (int(lat_text[:2]) + float(lat_text[2:]) / 60.0) * (1 if lat_n else -1)
            lon_w = (int(lon_text[:3]) + float(lon_text[3:]) / 60.0) * (1 if lon_e else -1)
            ns, ew = ("N" if lat_n else "S"), ("E" if lon_e else "W")
            knots = a.speed / 0.514444
            if fix:
                out.write(sentence(f"GPGGA,{stamp},{lat_text},{ns},{lon_text},{ew},1,10,{a.hdop:.1f},"
                                   f"{a.alt:.1f},M,0.0,M,,"))
                out.write(sentence(f"GPRMC,{stamp},A,{lat_text},{ns},{lon_text},{ew},{knots:.2f},"
                                   f"{heading:.2f},251126,,,A"))
                truth.writerow([i, f"{t:.2f}", 1, f"{lat_w:.9f}", f"{lon_w:.9f}", f"{a.alt:.1f}",
                                f"{heading:.2f}", f"{a.speed:.3f}"])
            else:
                out.write(sentence(f"GPGGA,{stamp},,,,,0,00,99.9,,,,,,"))
                out.write(sentence(f"GPRMC,{stamp},V,,,,,,,251126,,,N"))
                truth.writerow([i, f"{t:.2f}", 0, "", "", "", "", ""])
            step = a.speed * a.period
            north += step * math.cos(math.radians(heading))
            east += step * math.sin(math.radians(heading))
            travelled += step
            if 0 <= a.diverge_after_m <= travelled and heading == a.heading_deg:
                heading = (a.heading_deg + a.diverge_deg) % 360.0


if __name__ == "__main__":
    main()
