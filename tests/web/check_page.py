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


def chromium_once(url, extra, profile, ready, timeout_s):
    """One headless Chromium run, its output and errors sent to files in profile. Polls ready() (did the run
    leave what was asked for?) until it holds or timeout_s pass, then kills Chromium's whole process group.
    Waiting on the process itself would not do: on CI (2 cores, the suite beside it) a screenshot run
    did not end within 60 s twice, and a run may also write its file and then hang at exit. Returns (ready,
    exit code or None, the end of its errors)."""
    # --no-sandbox: tests run as root here; --virtual-time-budget: the page's timers (its polling) run
    # for that long, network waits not counted, before the DOM is dumped.
    args = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--hide-scrollbars",
            "--user-data-dir=" + profile, "--window-size=1400,1500", "--virtual-time-budget=3000"] + extra + [url]
    out_path, err_path = os.path.join(profile, "stdout"), os.path.join(profile, "stderr")
    with open(out_path, "w") as out, open(err_path, "w") as err:
        p = subprocess.Popen(args, stdout=out, stderr=err, start_new_session=True)
    deadline = time.monotonic() + timeout_s
    ok = False
    while time.monotonic() < deadline:
        ok = ready(out_path)
        if ok:
            break
        if p.poll() is not None:  # ended without it: a last look once its output is flushed
            deadline = min(deadline, time.monotonic() + 1.0)
        time.sleep(0.2)
    rc = p.poll()
    try:
        os.killpg(p.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    p.wait()
    with open(err_path, errors="replace") as f:  # less the D-Bus complaints of a machine without a session bus
        err_tail = "".join(line for line in f if "dbus/" not in line)[-2000:]
    return ok, rc, err_tail


def chromium(url, extra, profile, ready, timeout_s=120):
    """Headless Chromium until ready(stdout path) holds, at most twice, each run in a fresh profile (a
    killed one may still be locked). Under --virtual-time-budget Chromium now and then never finishes, more
    often on a loaded machine. Returns (ready, a line saying how the last run ended)."""
    why = ""
    for _ in range(2):
        ok, rc, err = chromium_once(url, extra, tempfile.mkdtemp(dir=profile), ready, timeout_s)
        if ok:
            return True, ""
        why = (("still running after %d s" % timeout_s if rc is None else "ended (exit %d) without it" % rc) +
               ": " + err.replace("\n", " | ")[-1500:])
    return False, why


def dumped_dom(out_path):
    """The whole document Chromium wrote to standard output (at once, ending with </html>), else None."""
    try:
        with open(out_path, errors="replace") as f:
            text = f.read()
    except OSError:
        return None
    return text if text.rstrip().endswith("</html>") else None


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
    dumped = []

    def ready(out_path):
        document = dumped_dom(out_path)
        if document is not None:
            dumped.append(document)
        return document is not None

    ok, why = chromium(url, ["--dump-dom"], profile, ready)
    if not ok:
        sys.exit("chromium --dump-dom failed twice: " + why)
    dom = Dom()
    dom.feed(dumped[-1])
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


def write_report(report, first, second):
    """One line, flat, every value a string: "first_seq": "55", "second_conditions_set": "Water,LowLight"."""
    flat = {}
    for name, load_ in (("first", first), ("second", second)):
        for key, value in load_.items():
            flat[name + "_" + key.replace("-", "_")] = ",".join(value) if isinstance(value, list) else str(value)
    with open(report, "w") as f:
        f.write(json.dumps(flat) + "\n")


def main():
    url, report = sys.argv[1], sys.argv[2]
    with tempfile.TemporaryDirectory() as profile:
        first = load(url, profile)
        time.sleep(1.0)
        second = load(url, profile)
        # Written before the screenshot, so that a failed screenshot does not hide what the page showed.
        write_report(report, first, second)
        if len(sys.argv) > 3:
            path = os.path.abspath(sys.argv[3])
            # The file decides: Chromium may hang at exit after writing it, or exit before it lands.
            ok, why = chromium(url, ["--screenshot=" + path], profile, lambda _: is_png(path))
            if not ok:
                sys.exit("chromium --screenshot failed twice: " + why)


if __name__ == "__main__":
    main()
