#!/bin/sh
# Runs inside the test guest (see init): records vcan0 with can-utils' candump while SENDER runs, then
# prints what happened between markers on the console:
#   RUTD-SENDER-EXIT=<status of SENDER>
#   ----- BEGIN sender-output -----   SENDER's stdout and stderr
#   ----- BEGIN candump.log -----     `candump -L vcan0`, ending with the end marker frame 7FF#
#   ----- BEGIN sent.log -----        the candump log SENDER wrote of the frames it says it sent
# (each block ends with ----- END <name> -----). SENDER must write that log to SENT_LOG.
# Usage: guest-candump.sh SENT_LOG SENDER [ARGS...]
set -u
sent_log=$1
shift
work=$(mktemp -d)

block() {  # block NAME FILE
  echo "----- BEGIN $1 -----"
  [ -f "$2" ] && cat "$2"
  echo "----- END $1 -----"
}

# Line-buffered, so the file is complete as soon as the end marker's line is in it.
stdbuf -oL candump -L vcan0 >"$work/candump.log" 2>"$work/candump.err" &
candump_pid=$!
# candump's receive filter shows in rcvlist_all once it listens ("(vcan0: no entry)" before).
i=0
until grep -q '^ *vcan0 ' /proc/net/can/rcvlist_all; do
  i=$((i + 1))
  if [ $i -gt 500 ]; then echo "guest-candump: candump never started listening"; cat "$work/candump.err"; exit 1; fi
  sleep 0.01
done

"$@" >"$work/sender.out" 2>&1
echo "RUTD-SENDER-EXIT=$?"

# The end marker: a frame rutd never sends. Frames reach candump in bus order, so once it is logged
# everything the sender put on the bus is logged too.
cansend vcan0 '7FF#'
i=0
until grep -q ' 7FF#$' "$work/candump.log"; do
  i=$((i + 1))
  if [ $i -gt 500 ]; then echo "guest-candump: candump never logged the end marker"; break; fi
  sleep 0.01
done
kill "$candump_pid"
wait "$candump_pid"

block sender-output "$work/sender.out"
block candump.log "$work/candump.log"
block sent.log "$sent_log"
