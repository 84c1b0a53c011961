#!/usr/bin/python3
"""Loads rutd's live view in headless Chromium and reports what the rendered page shows.

usage: check_page.py URL REPORT_JSON [SCREENSHOT_PNG]

The page is loaded twice, a second or more apart, each time with a few seconds of the page's own
polling (virtual time), and its DOM after the scripts ran is read with Python's own HTML parser. The
report (one JSON object) holds, per load: the pair shown (seq), the figures as displayed, the status
and the set condition and health bits, and for each picture the pair it shows (data-seq) and its decoded
width (data-width, from the browser's decoder). The test compares them with the measurement CSV."""
import html.parser
import json
import os
import signal
import subprocess
import sys
import tempfile
import time

CHROMIUM = "/usr/bin/chromium"


def chromium_once(url, extra, profile, timeout_s):
    """One headless Chromium run; None when it had not exited after timeout_s (it and its children killed)."""
    # --no-sandbox: tests run as root here; --virtual-time-budget: the page's timers (its polling) run
    # for that long, network waits not counted, before the DOM is dumped.
    args = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--hide-scrollbars",
            "--user-data-dir=" + profile, "--window-size=1400,1500", "--virtual-time-budget=3000"] + extra + [url]
    with subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                          start_new_session=True) as p:
        try:
            out, err = p.communicate(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.communicate()
            return None
    return subprocess.CompletedProcess(args, p.returncode, out, err)


def chromium(url, extra, profile, done):
    """Headless Chromium until done(run) holds, at most twice. Under --virtual-time-budget Chromium now and
    then never exits, before or after writing its output (a known headless Chromium behaviour, more often on
    a loaded machine: once in a sanitizer run here); a run that hangs is killed and the page loaded once more,
    in a fresh profile (the killed one may still be locked). Returns the last run (None: it hung)."""
    run = None
    for _ in range(2):
        run = chromium_once(url, extra, tempfile.mkdtemp(dir=profile), 60)
        if done(run):
            break
    return run


def is_png(path):
    """A whole PNG file: its signature first, its IEND chunk last."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError:
        return False
    return data.startswith(b"\x89PNG\r\n\x1a\n") and data.endswith(b"IEND\xaeB`\x82")


class Dom(html.parser.HTMLParser):
    def __init__(self):
        super().__init__()
        self.by_id = {}     # id -> {"attrs": {...}, "text": "..."}
        self.stack = []     # open elements with an id, innermost last

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag in ("img", "br", "meta", "link", "input"):
            if "id" in a:
                self.by_id[a["id"]] = {"attrs": a, "text": ""}
            return
        entry = None
        if "id" in a:
            entry = {"attrs": a, "text": ""}
            self.by_id[a["id"]] = entry
        self.stack.append(entry)

    def handle_endtag(self, tag):
        if tag in ("img", "br", "meta", "link", "input"):
            return
        if self.stack:
            self.stack.pop()

    def handle_data(self, data):
        for entry in self.stack:
            if entry is not None:
                entry["text"] += data


def load(url, profile):
    run = chromium(url, ["--dump-dom"], profile, lambda r: r is not None and r.returncode == 0 and "<html" in r.stdout)
    if run is None:
        sys.exit("chromium did not exit within 60 s, twice")
    if run.returncode != 0 or "<html" not in run.stdout:
        sys.exit("chromium failed (%d): %s" % (run.returncode, run.stderr[-2000:]))
    dom = Dom()
    dom.feed(run.stdout)
    ids = dom.by_id

    def text(i):
        return ids[i]["text"].strip() if i in ids else None

    def bits(list_id):
        return sorted(i[len(list_id) + 1:] for i, e in ids.items()
                      if i.startswith(list_id + "-") and "set" in e["attrs"].get("class", "").split())

    def listed(list_id):
        return sum(1 for i in ids if i.startswith(list_id + "-"))

    out = {name: text(name) for name in ("seq", "status", "depth", "width", "advisory", "connection", "updates",
                                        "focus-left", "focus-right", "sat-left", "skew", "rate", "published-rate")}
    out["conditions_set"] = bits("conditions")
    out["health_set"] = bits("health")
    out["conditions_listed"] = listed("conditions")
    out["health_listed"] = listed("health")
    for img in ("img-left", "img-right", "img-strip"):
        a = ids.get(img, {"attrs": {}})["attrs"]
        out[img + "-seq"] = int(a.get("data-seq", "0") or 0)
        out[img + "-width"] = int(a.get("data-width", "0") or 0)
    return out


def main():
    url, report = sys.argv[1], sys.argv[2]
    with tempfile.TemporaryDirectory() as profile:
        first = load(url, profile)
        time.sleep(1.0)
        second = load(url, profile)
        if len(sys.argv) > 3:
            path = os.path.abspath(sys.argv[3])
            # The file decides: Chromium may hang at exit after writing it.
            shot = chromium(url, ["--screenshot=" + path], profile, lambda r: is_png(path))
            if not is_png(path):
                sys.exit("chromium screenshot failed: " + ("no exit within 60 s, twice" if shot is None
                                                           else shot.stderr[-2000:]))
    # One line, flat, every value a string: "first_seq": "55", "second_conditions_set": "Water,LowLight".
    flat = {}
    for name, load_ in (("first", first), ("second", second)):
        for key, value in load_.items():
            flat[name + "_" + key.replace("-", "_")] = ",".join(value) if isinstance(value, list) else str(value)
    with open(report, "w") as f:
        f.write(json.dumps(flat) + "\n")


if __name__ == "__main__":
    main()
