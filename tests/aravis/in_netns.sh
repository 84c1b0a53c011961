#!/bin/sh
# Runs a test program in a network namespace of its own whose loopback carries 127.0.0.1 and 127.0.0.2,
# so that two fake GigE Vision cameras (each answering on UDP port 3956 of its address) run side by side,
# and tests running in parallel never see each other's cameras. Root gets the namespace directly; others
# get it inside a user namespace. Where neither is allowed the program runs as it is, and tests that need
# the second address skip, saying so.
setup='ip link set lo up && ip addr add 127.0.0.2/8 dev lo && exec "$@"'
if unshare -n true 2>/dev/null; then
  exec unshare -n sh -c "$setup" sh "$@"
elif unshare -rn true 2>/dev/null; then
  exec unshare -rn sh -c "$setup" sh "$@"
fi
exec "$@"
