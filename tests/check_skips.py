#!/usr/bin/env python3
"""Checks the skipped tests of CTest runs against the tests that may skip (tests/ci_skips.txt).

Usage: tests/check_skips.py ALLOWED JUNIT.xml...
JUNIT: CTest's --output-junit files (scripts/test and scripts/test-deep write one per build folder).
Prints every skipped test with its reason; exits 1 when one is not matched by ALLOWED, 2 when a file
cannot be read. .ci/run runs it after each tier, so a new skip cannot pass CI unnoticed.
"""
import re
import sys
import xml.etree.ElementTree as ET


def allowed_patterns(path):
    patterns = []
    with open(path) as f:
        for line in f:
            line = line.strip()
            if line and not line.startswith("#"):
                patterns.append(re.compile(line.split()[0]))
    return patterns


def skip_reason(output):
    """The line after GoogleTest's "Skipped", or a script's "SKIPPED: ..." line; else the last line."""
    lines = [l for l in (output or "").splitlines() if l.strip()]
    for i, line in enumerate(lines):
        if line.endswith(": Skipped") and i + 1 < len(lines):
            return lines[i + 1].strip()
        if "SKIPPED:" in line:
            return line.strip()
    return lines[-1].strip() if lines else "(no output)"


def main():
    if len(sys.argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    try:
        patterns = allowed_patterns(sys.argv[1])
    except OSError as e:
        print(f"check_skips: {e}", file=sys.stderr)
        return 2
    unexpected = []
    for junit in sys.argv[2:]:
        try:
            cases = ET.parse(junit).getroot().iter("testcase")
        except (OSError, ET.ParseError) as e:
            print(f"check_skips: {junit}: {e}", file=sys.stderr)
            return 2
        count = skipped = 0
        for case in cases:
            count += 1
            if case.find("skipped") is None:
                continue
            skipped += 1
            name = case.get("name")
            ok = any(p.fullmatch(name) for p in patterns)
            print(f"check_skips: {junit}: {'allowed' if ok else 'NOT ALLOWED'}: {name}: "
                  f"{skip_reason(case.findtext('system-out'))}")
            if not ok:
                unexpected.append(name)
        print(f"check_skips: {junit}: {count} tests, {skipped} skipped")
    if unexpected:
        print(f"check_skips: {len(unexpected)} test(s) skipped that must run here (tests/skip_policy.hpp): "
              + ", ".join(unexpected), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
