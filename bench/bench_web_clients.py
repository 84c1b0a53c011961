#!/usr/bin/python3
"""The live view under load: does polling it cost the measurement anything?

usage: bench_web_clients.py [--rutd build/bin/rutd] [--clients 20] [--hz 5] [--seconds 30] [--rounds 2]
                            [--long SECONDS]

Runs `rutd run` on its synthetic cameras (640x480 at 30 Hz, the embedded default) in turn with the web
view off, on without clients, and on with CLIENTS clients each polling at HZ: every tick GET /api/live.json
and one of /, /api/history.json, /api/image/left.jpg, right.jpg, strip.png in turn (two requests a tick,
the page's own pattern). The clients run on this machine too, at nice 19 by default (--clients-nice), so that they take only
the CPU rutd leaves, as clients on other machines would; their CPU share is printed.
Per run it prints the pairs rutd acquired and published (its own final summary), its steady published
rate (periodic summaries after the first 4 s), its end-to-end latency, its resident
memory (VmRSS) at 5 s, at 60 s (the view's minute of history full) and at the end (the clients stop before rutd is stopped), and the clients' requests, errors and answer times."""
import argparse
import os
import re
import subprocess
import tempfile
import threading
import time
import urllib.request


NICE = [0]  # the clients' niceness, undone for rutd


def rss_kib(pid):
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def client(port, hz, stop, stats, index):
    others = ["/", "/api/history.json", "/api/image/left.jpg", "/api/image/right.jpg", "/api/image/strip.png"]
    tick = 1.0 / hz
    next_t = time.monotonic() + tick * index / 20.0
    n = index
    while not stop.is_set():
        for path in ("/api/live.json", others[n % len(others)]):
            t0 = time.monotonic()
            try:
                with urllib.request.urlopen("http://127.0.0.1:%d%s" % (port, path), timeout=5) as r:
                    r.read()
                    ok = r.status == 200
            except Exception:
                ok = False
            dt = time.monotonic() - t0
            with stats["lock"]:
                stats["requests"] += 1
                stats["errors"] += 0 if ok else 1
                stats["times"].append(dt)
        n += 1
        next_t += tick
        time.sleep(max(0.0, next_t - time.monotonic()))


def run(rutd, cfg, seconds, clients, hz, web):
    with tempfile.NamedTemporaryFile("w+", suffix=".log") as log:
        p = subprocess.Popen(["nice", "-n", str(-NICE[0]), rutd, "run", "--config", cfg, "--candump", ""], stderr=log,
                             stdout=subprocess.DEVNULL)
        # The clients start with the first measurement (before it the data paths answer 503).
        port = None
        for _ in range(400):
            time.sleep(0.05)
            text = open(log.name).read()
            m = re.search(r"web view at http://[^:]+:(\d+)/", text)
            if m:
                port = int(m.group(1))
            if "ready: first good measurement" in text:
                break
        stats = {"lock": threading.Lock(), "requests": 0, "errors": 0, "times": []}
        stop = threading.Event()
        threads = [threading.Thread(target=client, args=(port, hz, stop, stats, i)) for i in range(clients)]
        for t in threads:
            t.start()
        rss = []
        t0 = time.monotonic()
        cpu0 = os.times()
        while time.monotonic() - t0 < seconds:
            time.sleep(0.5)
            rss.append((time.monotonic() - t0, rss_kib(p.pid)))
        stop.set()
        for t in threads:
            t.join()
        cpu1 = os.times()
        clients_cpu = (cpu1.user + cpu1.system - cpu0.user - cpu0.system) / (time.monotonic() - t0)
        p.terminate()
        p.wait(timeout=30)
        text = open(log.name).read()
    m = re.search(r"stopped: acquired (\d+) \(([\d.]+) Hz\) published (\d+) \(([\d.]+) Hz.*? dropped (\d+) stale (\d+)"
                  r".*?e2e p50 ([\d.]+) p99 ([\d.]+)", text)
    if not m:
        raise SystemExit("no final summary from rutd:\n" + text[-3000:])
    # The steady rate: published pairs between the periodic summaries at 5 s and the last one, over the
    # time between them (the final rate also counts the start).
    ticks = [(float(t[0]) * 3600 + float(t[1]) * 60 + float(t[2]), int(t[3])) for t in re.findall(
        r"T(\d\d):(\d\d):([\d.]+) info acquired \d+ \([^)]*\) published (\d+)", text)]
    steady = [(t, n) for t, n in ticks if t - ticks[0][0] >= 4] if ticks else []
    rate = (steady[-1][1] - steady[0][1]) / (steady[-1][0] - steady[0][0]) if len(steady) >= 2 else float("nan")
    early = next((kib for t, kib in rss if t >= 5), rss[0][1] if rss else 0)
    # After a minute the view's history (600 bins of 0.1 s) is full: from there on, flat means flat.
    minute = next((kib for t, kib in rss if t >= 60), None)
    late = rss[-1][1] if rss else 0
    times = sorted(stats["times"])
    pct = lambda q: times[min(len(times) - 1, int(q * len(times)))] * 1000 if times else float("nan")
    return {"acquired": int(m.group(1)), "published": int(m.group(3)), "dropped": int(m.group(5)) + int(m.group(6)),
            "published_hz": rate, "p50": float(m.group(7)), "p99": float(m.group(8)),
            "rss_early": early, "rss_minute": minute, "rss_late": late, "requests": stats["requests"], "errors": stats["errors"],
            "client_p50": pct(0.5), "client_p99": pct(0.99), "clients_cpu": clients_cpu}


def main():
    a = argparse.ArgumentParser()
    a.add_argument("--rutd", default=os.path.join(os.path.dirname(__file__), "..", "build", "bin", "rutd"))
    a.add_argument("--clients", type=int, default=20)
    a.add_argument("--hz", type=float, default=5)
    a.add_argument("--seconds", type=float, default=30)
    a.add_argument("--rounds", type=int, default=2)
    a.add_argument("--long", type=float, default=0, help="then one run this long with the clients, for memory")
    a.add_argument("--clients-nice", type=int, default=19,
                   help="the clients' niceness (19: they take only the CPU rutd leaves, as clients on other "
                        "machines would; 0: they compete with it)")
    o = a.parse_args()
    # The clients' threads are this process's; rutd, started by it, gets its own niceness back (root only:
    # elsewhere the clients stay at rutd's niceness, and say so).
    if o.clients_nice and os.geteuid() == 0:
        os.nice(o.clients_nice)
        NICE[0] = o.clients_nice
    elif o.clients_nice:
        print("not root: the clients run at rutd's niceness and compete with it")
    configs = {}
    for web in (False, True):
        with tempfile.NamedTemporaryFile("w", suffix=".yaml", delete=False) as f:
            # The embedded default's source: 8 pairs rendered once and played at 30 Hz, as cameras deliver.
            f.write("source:\n  synthetic:\n    cycle_frames: 8\n")
            f.write("web:\n  enabled: true\n  port: 0\n" if web else "")
            configs[web] = f.name
    rows = []
    modes = (("web off", False, 0), ("web on", True, 0), ("web on", True, o.clients))
    for r in range(o.rounds):
        for name, web, clients in modes:
            res = run(o.rutd, configs[web], o.seconds, clients, o.hz, web)
            rows.append(((web, clients), res))
            print("round %d, %s, %2d clients: published %d of %d pairs (%d dropped or stale), steady %.2f Hz, "
                  "e2e p50 %.2f p99 %.2f ms, RSS %d (5 s) -> %s (60 s) -> %d KiB (end), %d requests (%d errors), answer p50 %.1f p99 %.1f ms, clients' CPU %.0f %% of a core" % (
                      r + 1, name, clients, res["published"], res["acquired"], res["dropped"], res["published_hz"],
                      res["p50"], res["p99"], res["rss_early"],
                      "-" if res["rss_minute"] is None else str(res["rss_minute"]), res["rss_late"], res["requests"], res["errors"],
                      res["client_p50"], res["client_p99"], 100 * res["clients_cpu"]), flush=True)
    if o.long > 0:
        res = run(o.rutd, configs[True], o.long, o.clients, o.hz, True)
        print("long run, %d clients, %.0f s: published %d of %d pairs, RSS %d KiB at 5 s, %s at 60 s, %d at the end; "
              "%d requests (%d errors)" % (o.clients, o.long, res["published"], res["acquired"], res["rss_early"],
                                           res["rss_minute"], res["rss_late"], res["requests"], res["errors"]), flush=True)
    for cfg in configs.values():
        os.unlink(cfg)
    if not rows:
        return
    mean = lambda k, mode: sum(res[k] for m, res in rows if m == mode) / sum(1 for m, _ in rows if m == mode)
    off, idle, loaded = (False, 0), (True, 0), (True, o.clients)
    print("mean over %d rounds: steady published rate %.2f Hz (web off), %.2f Hz (web on), %.2f Hz (%d clients: "
          "%+.2f %% against web on); e2e p99 %.2f, %.2f, %.2f ms (%+.1f %%)" % (
              o.rounds, mean("published_hz", off), mean("published_hz", idle), mean("published_hz", loaded), o.clients,
              100 * (mean("published_hz", loaded) / mean("published_hz", idle) - 1), mean("p99", off), mean("p99", idle),
              mean("p99", loaded), 100 * (mean("p99", loaded) / mean("p99", idle) - 1)))


if __name__ == "__main__":
    main()
