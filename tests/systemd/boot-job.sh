#!/bin/sh
# The job of the systemd boot test (boot-systemd.sh), inside the guest (tests/can/qemu/init with
# rutd.init=systemd). Two phases:
#   boot-job.sh WORK --setup   chrooted in the guest's root before systemd starts: installs the package
#                              WORK/params names (PACKAGE_A) with dpkg, as on a vehicle PC (its postinst
#                              creates the user, applies the tmpfiles entry and enables the unit; no
#                              systemd runs yet, so nothing starts), edits the installed configuration
#                              for the synthetic source, and adds the drop-ins for an emulated CPU
#                              (WORK/params: RUTD_OPTIONS, WATCHDOG_S).
#   boot-job.sh WORK           as a unit of multi-user.target under systemd as PID 1: checks rutd.service,
#                              then the package's upgrade (PACKAGE_B), removal, purge, a fresh install on
#                              the vehicle configuration and an install with a dependency missing; prints
#                              one line per check,
#                                RUTD-CHECK <name> <figure> <bound> PASS|FAIL
#                              and exits 1 when one failed.
# The shipped unit is never edited: everything the emulation needs is a drop-in.
set -u
work=$1
. "$work/params"  # RUTD_OPTIONS, WATCHDOG_S, STALL_AFTER, PACKAGE_A/B, VERSION_A/B, SOURCE_DIR

if [ "${2:-}" = --setup ]; then
  set -e
  # man-db rebuilds its index of manual pages at every install and removal (a dpkg trigger): minutes under
  # emulation for something not under test here. Off in this guest, as on a machine without man pages.
  rm -f /var/lib/man-db/auto-update
  # The host root may come from a container image whose policy-rc.d forbids maintainer scripts to start
  # services (exit 101: deb-systemd-invoke then refuses the restart on upgrade). A vehicle PC has none.
  rm -f /usr/sbin/policy-rc.d
  dpkg -i "$PACKAGE_A" </dev/null >/var/tmp/rutd-dpkg-install.log 2>&1 ||
    { cat /var/tmp/rutd-dpkg-install.log; exit 1; }
  # The guest has no cameras: the installed configuration's source (aravis) becomes the synthetic one,
  # as an integrator sets it up on a bench. Everything else stays as installed but for the synthetic
  # camera's pace, for the emulated CPU: 5 pairs a second instead of 30 (at 30 Hz rutd kept the guest
  # busy with pairs it then dropped, while dpkg and systemctl waited) and 2 pairs rendered at each of
  # rutd's seven starts instead of 8. Measured alone on two CPUs: the guest's run 385 -> 338 s, the
  # emulator's CPU time 380 -> 295 s; with the rest of the suite beside it, the CPUs it no longer takes
  # are theirs.
  sed -i 's/^  type: aravis /  type: synthetic/; s|^calibration: /etc/rutd/calibration.yaml|calibration: ""|' /etc/rutd/rutd.yaml
  sed -i '/^  synthetic:/,/^  replay:/ { s/^    fps: 30\b/    fps: 5/; s/^    cycle_frames: 8\b/    cycle_frames: 2/ }' /etc/rutd/rutd.yaml
  grep -q '^  type: synthetic' /etc/rutd/rutd.yaml
  [ "$(sed -n '/^  synthetic:/,/^  replay:/ { /^    fps: 5\b/p; /^    cycle_frames: 2\b/p }' /etc/rutd/rutd.yaml | wc -l)" = 2 ]
  exec_start=$(sed -n 's/^ExecStart=//p' /lib/systemd/system/rutd.service)
  mkdir -p /etc/systemd/system/rutd.service.d
  cat >/etc/systemd/system/rutd.service.d/50-emulated-cpu.conf <<EOF
# The boot test runs under qemu's emulation (TCG), about a hundred times slower than the vehicle PC: a
# small synthetic image and the quickest engine (else every pair is stale: nothing would be published),
# a watchdog period that a working pipeline keeps on such a CPU, and a start-up limit that leaves room
# for a host core shared with other tests (READY=1 comes 30 s of rutd's time after the start at most).
[Service]
WatchdogSec=${WATCHDOG_S}s
TimeoutStartSec=120s
ExecStart=
ExecStart=$exec_start $RUTD_OPTIONS
EOF
  exit 0
fi

unit=rutd.service
failed=0
now() { cut -d' ' -f1 /proc/uptime; }
prop() { systemctl show -p "$1" --value "$unit"; }
# seconds between two CLOCK_MONOTONIC microsecond figures
us_to_s() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", (b - a) / 1e6 }'; }
sub() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", b - a }'; }
check() {  # check NAME FIGURE BOUND OK(0|1) [detail]
  if [ "$4" = 1 ]; then verdict=PASS; else verdict=FAIL; failed=1; fi
  echo "RUTD-CHECK $1 $2 $3 $verdict${5:+ $5}"
}
within() { awk -v a="$1" -v b="$2" 'BEGIN { exit !(a <= b) }'; }  # within FIGURE BOUND: a status
le() { within "$1" "$2" && echo 1 || echo 0; }
# wait_for TIMEOUT_S COMMAND...: polls every 0.1 s; false when the time is up
wait_for() {
  limit=$(awk -v t="$(now)" -v d="$1" 'BEGIN { print t + d }')
  shift
  until "$@"; do
    awk -v t="$(now)" -v l="$limit" 'BEGIN { exit !(t > l) }' && return 1
    sleep 0.1
  done
}
is_state() { [ "$(prop ActiveState)" = "$1" ]; }
new_pid() { p=$(prop MainPID); [ "$p" != 0 ] && [ "$p" != "$1" ]; }
journal_has() { journalctl -b -u "$unit" -o cat --no-pager | grep -q "$1"; }
stall_dropin() {  # stall_dropin N: the test-only switch that stalls the match stage after N pairs
  mkdir -p /run/systemd/system/$unit.d
  printf '[Service]\nExecStart=\nExecStart=%s %s --test-stall-match-after %s\n' \
    "$(sed -n 's/^ExecStart=//p' /lib/systemd/system/rutd.service)" "$RUTD_OPTIONS" "$1" \
    >/run/systemd/system/$unit.d/60-stall.conf
  systemctl daemon-reload
}
no_stall() {
  rm -f /run/systemd/system/$unit.d/60-stall.conf
  systemctl daemon-reload
}

# 1. Boot: multi-user.target waits for rutd's READY=1 (the target is ordered after what it wants).
wait_for 300 sh -c '[ "$(systemctl show -p ActiveEnterTimestampMonotonic --value multi-user.target)" != 0 ]'
boot_us=$(systemctl show -p ActiveEnterTimestampMonotonic --value multi-user.target)
echo "RUTD-FIGURE boot_to_multi_user_s $(us_to_s 0 "$boot_us")"
systemd-analyze time --no-pager 2>/dev/null | sed 's/^/RUTD-INFO /'
wait_for 90 is_state active
start_us=$(prop ExecMainStartTimestampMonotonic)
active_us=$(prop ActiveEnterTimestampMonotonic)
ready=0
journal_has '^.* ready: ' && [ "$(prop ActiveState)" = active ] && [ "$(prop NRestarts)" = 0 ] && ready=1
check time_to_active_s "$(us_to_s "$start_us" "$active_us")" "<=120(TimeoutStartSec)" "$ready" \
  "(READY=1 logged: $(journal_has ' ready: ' && echo yes || echo no), restarts $(prop NRestarts))"

# 2. Journal lines per minute of rutd in steady state, over a window after READY=1.
window_s=20
t0=$(date +%s)
sleep "$window_s"
t1=$(date +%s)
lines=$(journalctl -u "$unit" --since "@$t0" --until "@$t1" -o cat --no-pager | wc -l)
all=$(journalctl --since "@$t0" --until "@$t1" -o cat --no-pager | wc -l)
per_min=$(awk -v n="$lines" -v s=$((t1 - t0)) 'BEGIN { printf "%.1f", n * 60 / s }')
check journal_lines_per_min "$per_min" "<=10" "$(le "$per_min" 10)" \
  "($lines rutd lines in $((t1 - t0)) s; all units: $all)"

# 3. kill -9 of the main process: a new one within RestartSec (2 s) plus a margin of 10 s. The guest is
# emulated (TCG): on a 2-core host busy with other builds (load average 14) it took 8.6 s.
# The new one starts with the test switch of step 4 (one start fewer under emulation).
stall_dropin 0
since=$(date +%s)
pid=$(prop MainPID)
t0=$(now)
kill -9 "$pid"
ok=0
wait_for 30 new_pid "$pid" && ok=1
t1=$(now)
check new_pid_after_kill9_s "$(sub "$t0" "$t1")" "<=12" "$([ $ok = 1 ] && le "$(sub "$t0" "$t1")" 12 || echo 0)"

# 4. The watchdog is armed only from READY=1 on: a first pair that never comes out of the stages (as on a
# loaded machine at boot) keeps the unit activating, not killed, for well over the watchdog period. The
# hold counts from the pipeline's start (rutd logs the test switch then), when rutd could first ping: a
# ping then would arm the watchdog, and the stall detected one period later would stop the pings.
wait_for 60 sh -c "journalctl -u rutd.service --since @$since -o cat | grep -q 'test switch: the match stage stalls'"
pid=$(prop MainPID)
restarts=$(prop NRestarts)
hold=$((WATCHDOG_S * 5 / 2))
t0=$(now)
steady=1
while awk -v t="$(now)" -v e="$(awk -v a="$t0" -v h="$hold" 'BEGIN { print a + h }')" 'BEGIN { exit !(t < e) }'; do
  # READY=1 at rutd's 30 s start-up limit may fall at the end of the hold: active is fine, killed is not.
  case $(prop ActiveState) in activating | active) ;; *) steady=0 ;; esac
  [ "$(prop MainPID)" = "$pid" ] || steady=0
  [ $steady = 1 ] || break
  sleep 0.2
done
check activating_without_watchdog_kill_s "$(sub "$t0" "$(now)")" ">=$hold" \
  "$([ $steady = 1 ] && [ "$(prop NRestarts)" = "$restarts" ] && echo 1 || echo 0)" \
  "(state $(prop ActiveState), pid $pid -> $(prop MainPID))"

# 5. A hung stage once ready: the pings stop, systemd kills rutd (Watchdog timeout) and restarts it.
stall_dropin "$STALL_AFTER"
systemctl restart "$unit"
pid=$(prop MainPID)
t_active=$(now)
since=$(date +%s)
# Back to the plain command line as soon as the stall shows, so that systemd's restart is a clean start.
wait_for $((WATCHDOG_S * 2 + 20)) sh -c "journalctl -u rutd.service --since @$since -o cat | grep -q 'pipeline stalled'"
no_stall
ok=0
wait_for $((WATCHDOG_S * 4 + 20)) new_pid "$pid" && ok=1
t_new=$(now)
killed=0
journalctl -u "$unit" --since "@$since" --no-pager -o cat | grep -q "Watchdog timeout" && killed=1
mono() { journalctl -u "$unit" --since "@$since" --no-pager -o short-monotonic | grep "$1" | tail -1 |
  sed -n 's/^\[ *\([0-9.]*\)\].*/\1/p'; }
# Stall detection (one period), systemd's timeout (one more), RestartSec, and room for the emulation.
hang_bound=$((WATCHDOG_S * 4 + 15))
check watchdog_kill_and_restart_s "$(sub "$t_active" "$t_new")" "<=$hang_bound" \
  "$([ $ok = 1 ] && [ $killed = 1 ] && le "$(sub "$t_active" "$t_new")" "$hang_bound" || echo 0)" \
  "(from READY=1 to the new process; uptime: ready $t_active, stall seen $(mono 'pipeline stalled'), \
watchdog kill $(mono 'Watchdog timeout'), new process $t_new)"
wait_for 90 is_state active
echo "RUTD-FIGURE active_again_after_watchdog_kill_s $(sub "$t_new" "$(now)")"

# 6. systemctl stop: SIGTERM, drained, exit 0 within TimeoutStopSec (5 s). The figure is systemd's, from
# the stop request to the process gone; the systemctl call itself, under emulation, takes longer.
t0=$(now)
systemctl stop "$unit"
t1=$(now)
clean=0
[ "$(prop Result)" = success ] && [ "$(prop ExecMainStatus)" = 0 ] && [ "$(prop ExecMainCode)" = 1 ] && clean=1
stop_s=$(us_to_s "$(prop ActiveExitTimestampMonotonic)" "$(prop InactiveEnterTimestampMonotonic)")
check stop_s "$stop_s" "<=5" "$([ $clean = 1 ] && le "$stop_s" 5 || echo 0)" \
  "(result $(prop Result), exit status $(prop ExecMainStatus); systemctl stop took $(sub "$t0" "$t1") s)"

# 7. The hardening as systemd rates it.
score=$(systemd-analyze security --no-pager "$unit" 2>/dev/null | sed -n 's/.*Overall exposure level for [^:]*: *\([0-9.]*\).*/\1/p')
check security_exposure "${score:-none}" "<=2.5" "$([ -n "$score" ] && le "$score" 2.5 || echo 0)"

# The package (packaging/). dpkg's output goes to the console as RUTD-DPKG lines.
show_log() { sed "s/^/RUTD-DPKG $1: /" "$2"; }
dpkg_status() { dpkg-query -W -f='${Status}' rutd 2>/dev/null || echo not-known; }
# Not running: no process, whatever systemd remembers of earlier runs (inactive, or failed).
not_running() { case $(prop ActiveState) in inactive | failed) [ "$(prop MainPID)" = 0 ] ;; *) return 1 ;; esac; }
forgotten() { case $(dpkg_status) in not-known | *not-installed) return 0 ;; *) return 1 ;; esac; }
config=/etc/rutd/rutd.yaml

# 8. What the package's postinst did at the install before boot: the user, the conffile, the unit enabled
# (check 1 saw it start at boot from that).
show_log install "/var/tmp/rutd-dpkg-install.log"
enabled=$(systemctl is-enabled "$unit" 2>/dev/null)
conffile=$(dpkg-query -W -f='${Conffiles}' rutd | grep -c " $config ")
user=$(getent passwd rutd | cut -d: -f1,7)
check enabled_by_package "$enabled" "enabled" \
  "$([ "$enabled" = enabled ] && [ "$(dpkg_status) $(dpkg-query -W -f='${Version}' rutd)" = "install ok installed $VERSION_A" ] &&
    [ "$conffile" = 1 ] && [ -n "$user" ] && echo 1 || echo 0)" \
  "(dpkg: $(dpkg_status) $(dpkg-query -W -f='${Version}' rutd); conffile $config: $conffile; user ${user:-none})"

# 9. Upgrade to the rebuilt package, one revision higher, while rutd runs, with the configuration edited
# on this vehicle (the synthetic source, and one more line): dpkg keeps the edit without asking (the
# package's own file did not change), the postinst restarts rutd, and the new version runs.
systemctl start "$unit"
wait_for 90 is_state active
echo "# edited on this vehicle" >>"$config"
sum_before=$(sha256sum "$config" | cut -d' ' -f1)
pid=$(prop MainPID)
t0=$(now)
status=0
dpkg -i "$PACKAGE_B" </dev/null >/var/tmp/rutd-dpkg-upgrade.log 2>&1 || status=$?
t_dpkg=$(now)
ok=0
wait_for 90 new_pid "$pid" && wait_for 90 is_state active && ok=1
t1=$(now)
show_log upgrade /var/tmp/rutd-dpkg-upgrade.log
running=$(rutd --version)
kept=0
[ "$(sha256sum "$config" | cut -d' ' -f1)" = "$sum_before" ] && kept=1
asked=$(grep -c "Configuration file" /var/tmp/rutd-dpkg-upgrade.log)
check upgrade_restart_s "$(sub "$t0" "$t1")" "<=180" \
  "$([ $status = 0 ] && [ $ok = 1 ] && [ $kept = 1 ] && [ "$asked" = 0 ] && within "$(sub "$t0" "$t1")" 180 &&
    [ "$(dpkg-query -W -f='${Version}' rutd)" = "$VERSION_B" ] && case $running in "rutd $VERSION_B "*) echo 1 ;; *) echo 0 ;; esac || echo 0)" \
  "(dpkg -i exit $status in $(sub "$t0" "$t_dpkg") s; pid $pid -> $(prop MainPID), $(prop ActiveState); configuration kept: $kept, \
asked: $asked; now: $running)"

# 10. The new version on the bus: RutSoftwareVersion from can0, decoded by canmatrix with the DBC.
candump -L can0 >/var/tmp/can0.log 2>/dev/null &
candump_pid=$!
sleep 3
kill "$candump_pid" 2>/dev/null
wait "$candump_pid" 2>/dev/null
/usr/bin/python3 "$SOURCE_DIR/tests/can/decode_candump.py" "$SOURCE_DIR/config/rutd.dbc" /var/tmp/can0.log \
  >/var/tmp/can0.csv 2>/var/tmp/can0.err
field() { awk -F, -v s="$1" '$3 == "RutSoftwareVersion" && $4 == s { v = $5 } END { print v }' /var/tmp/can0.csv; }
on_bus="$(field SwVersionMajor).$(field SwVersionMinor).$(field SwVersionPatch)-$(field SwPackageRevision)"
versions=$(awk -F, '$3 == "RutSoftwareVersion" && $4 == "SwVersionMajor"' /var/tmp/can0.csv | wc -l)
summary=$(tail -1 /var/tmp/can0.err)
check can_software_version "$on_bus" "=$VERSION_B" \
  "$([ "$on_bus" = "$VERSION_B" ] && [ "$versions" -ge 2 ] && case $summary in *" crc_errors=0 "*) echo 1 ;; *) echo 0 ;; esac || echo 0)" \
  "($versions RutSoftwareVersion frames in 3 s; decoder: $summary)"

# 11. Removal: rutd stops, the unit is gone from systemd; the configuration stays (it is a conffile).
pid=$(prop MainPID)
t0=$(now)
status=0
dpkg -r rutd </dev/null >/var/tmp/rutd-dpkg-remove.log 2>&1 || status=$?
t1=$(now)
show_log remove /var/tmp/rutd-dpkg-remove.log
gone=1
kill -0 "$pid" 2>/dev/null && gone=0
kept=0
grep -q '^# edited on this vehicle$' "$config" && kept=1
check remove_s "$(sub "$t0" "$t1")" "<=60" \
  "$([ $status = 0 ] && [ $gone = 1 ] && [ "$(prop LoadState)" = not-found ] && [ ! -e /lib/systemd/system/$unit ] &&
    [ $kept = 1 ] && [ "$(dpkg_status)" = "deinstall ok config-files" ] && within "$(sub "$t0" "$t1")" 60 && echo 1 || echo 0)" \
  "(dpkg -r exit $status; process $pid gone: $gone; unit $(prop LoadState); configuration kept: $kept; dpkg: $(dpkg_status))"

# 12. Purge: nothing left under /etc/rutd or /var/lib/rutd (the working directory), the enablement gone.
before=$(find /etc/rutd /var/lib/rutd 2>/dev/null | wc -l)
status=0
dpkg -P rutd </dev/null >/var/tmp/rutd-dpkg-purge.log 2>&1 || status=$?
show_log purge /var/tmp/rutd-dpkg-purge.log
left=$(find /etc/rutd /var/lib/rutd 2>/dev/null | wc -l)
wants=$(find /etc/systemd/system -name "$unit" 2>/dev/null | wc -l)
check purge_leaves_files "$left" "=0" \
  "$([ $status = 0 ] && [ "$before" -gt 0 ] && [ "$left" = 0 ] && [ "$wants" = 0 ] && forgotten && echo 1 || echo 0)" \
  "(dpkg -P exit $status; $before entries before; enablement links left: $wants; dpkg: $(dpkg_status))"

# 13. A fresh install with systemd running, on the vehicle configuration as shipped (cameras not set): the
# unit is enabled and not started, and the postinst says why.
since=$(date +%s)
status=0
dpkg -i "$PACKAGE_A" </dev/null >/var/tmp/rutd-dpkg-fresh.log 2>&1 || status=$?
show_log fresh /var/tmp/rutd-dpkg-fresh.log
said=0
grep -q "rutd: enabled, not started: .*source.aravis.left" /var/tmp/rutd-dpkg-fresh.log && said=1
sleep 2
starts=$(journalctl -u "$unit" --since "@$since" -o cat --no-pager | grep -c '^Start')
check unconfigured_not_started "$(prop ActiveState)" "not_running" \
  "$([ $status = 0 ] && [ $said = 1 ] && [ "$(systemctl is-enabled "$unit" 2>/dev/null)" = enabled ] &&
    not_running && [ "$starts" = 0 ] && echo 1 || echo 0)" \
  "(dpkg -i exit $status; enabled: $(systemctl is-enabled "$unit" 2>/dev/null); start jobs: $starts; postinst said why: $said)"

# 14. Started all the same, as at every boot of a vehicle PC not configured yet: rutd fails once with the
# reason (exit 2, bad input) and is not restarted (RestartPreventExitStatus=2), so no loop every
# RestartSec fills the journal.
restarts=$(prop NRestarts)
since=$(date +%s)
systemctl start "$unit" >/dev/null 2>&1
wait_for 60 is_state failed
sleep 8  # four RestartSec periods: a restart would have come
reason=$(journalctl -u "$unit" --since "@$since" -o cat --no-pager | grep -c 'source\.aravis\.left')
check unconfigured_start_fails_once "$(($(prop NRestarts) - restarts))" "=0" \
  "$([ "$(prop NRestarts)" = "$restarts" ] && [ "$(prop ActiveState)" = failed ] && [ "$(prop ExecMainStatus)" = 2 ] &&
    [ "$reason" -ge 1 ] && echo 1 || echo 0)" \
  "(restarts; state $(prop ActiveState), exit status $(prop ExecMainStatus), journal lines naming source.aravis.left: $reason)"
dpkg -P rutd </dev/null >/dev/null 2>&1

# 15. A machine without one of the dependencies dpkg-shlibdeps computed (yaml-cpp's library, unregistered
# here): dpkg refuses to configure rutd with its own message, so nothing is enabled or started.
dependency=$(dpkg-deb --field "$PACKAGE_A" Depends | tr ',' '\n' | sed -n 's/^ *\(libyaml-cpp[^ ]*\).*/\1/p')
dpkg --remove --force-depends "$dependency" </dev/null >/var/tmp/rutd-dpkg-unregister.log 2>&1
status=0
dpkg -i "$PACKAGE_A" </dev/null >/var/tmp/rutd-dpkg-missing.log 2>&1 || status=$?
show_log missing /var/tmp/rutd-dpkg-missing.log
refused=0
grep -q "dependency problems prevent configuration of rutd" /var/tmp/rutd-dpkg-missing.log &&
  grep -q "rutd depends on $dependency" /var/tmp/rutd-dpkg-missing.log && refused=1
state=$(dpkg-query -W -f='${db:Status-Abbrev}' rutd 2>/dev/null)
check missing_dependency_refused "$status" "!=0" \
  "$([ -n "$dependency" ] && [ "$status" != 0 ] && [ $refused = 1 ] && [ "$state" = "iU " ] &&
    not_running && [ "$(systemctl is-enabled "$unit" 2>/dev/null)" != enabled ] && echo 1 || echo 0)" \
  "(without ${dependency:-no libyaml-cpp in Depends}: dpkg -i exit $status, its message: $refused, dpkg: '$state')"

journalctl -b -u "$unit" --no-pager -o short-monotonic | cut -c1-240 | sed 's/^/RUTD-JOURNAL /'
echo "RUTD-FIGURE job_done_uptime_s $(now)"
exit "$failed"
