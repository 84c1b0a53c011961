#!/usr/bin/env bash
# A Mosquitto broker for the uplink tests, generated into DIR: a test CA made by openssl (and a second,
# unrelated CA for the wrong-CA case), the broker's certificate for 127.0.0.1 and localhost, per-vehicle
# credentials (truck-7, truck-8: passwords pw-truck-7, pw-truck-8) and a reader (fleet, pw-fleet), and an
# ACL by which a vehicle may publish only under rutd/<its user name>/ while the fleet reads everything.
# TLS on PORT; persistence in DIR (a subscriber's QoS 1 session survives a broker restart); no bound on what
# the broker queues for a slow subscriber (Mosquitto's default drops beyond 1000 messages).
# With CERT_PORT, a second listener there takes client certificates instead of passwords (each vehicle's
# certificate, truck-7.crt and truck-7.key, signed by the test CA; its common name is its user name).
# Usage: make_broker.sh DIR PORT [CERT_PORT]    (then: mosquitto -c DIR/mosquitto.conf)
set -euo pipefail
dir=$1
port=$2
cert_port=${3:-}
mkdir -p "$dir"
cd "$dir"
quiet() { "$@" >/dev/null 2>&1; }
quiet openssl req -x509 -newkey rsa:2048 -nodes -days 2 -subj "/CN=rutd test CA" -keyout ca.key -out ca.crt
quiet openssl req -x509 -newkey rsa:2048 -nodes -days 2 -subj "/CN=another CA" -keyout other-ca.key -out other-ca.crt
quiet openssl req -newkey rsa:2048 -nodes -subj "/CN=localhost" -keyout server.key -out server.csr
printf 'subjectAltName=IP:127.0.0.1,DNS:localhost\n' >server.ext
quiet openssl x509 -req -in server.csr -CA ca.crt -CAkey ca.key -CAcreateserial -days 2 -extfile server.ext \
  -out server.crt
for user in truck-7; do
  quiet openssl req -newkey rsa:2048 -nodes -subj "/CN=$user" -keyout "$user.key" -out "$user.csr"
  quiet openssl x509 -req -in "$user.csr" -CA ca.crt -CAkey ca.key -CAcreateserial -days 2 -out "$user.crt"
  chmod 600 "$user.key"
done
: >passwd
for user in truck-7 truck-8 fleet; do mosquitto_passwd -b passwd "$user" "pw-$user"; done
chmod 600 passwd
for user in truck-7 truck-8; do
  printf '%s\npw-%s\n' "$user" "$user" >"$user.credentials"
  chmod 600 "$user.credentials"
done
printf 'truck-7\nwrong\n' >wrong.credentials
chmod 600 wrong.credentials
cat >acl <<ACL
user fleet
topic read rutd/#

pattern write rutd/%u/#
ACL
cat >mosquitto.conf <<CONF
per_listener_settings false
allow_anonymous false
password_file $dir/passwd
acl_file $dir/acl
max_queued_messages 0
persistence true
persistence_location $dir/
autosave_interval 1
user root
log_dest stdout
log_type error
log_type warning
log_type notice
listener $port 127.0.0.1
cafile $dir/ca.crt
certfile $dir/server.crt
keyfile $dir/server.key
tls_version tlsv1.2
CONF
if [ -n "$cert_port" ]; then
  cat >>mosquitto.conf <<CONF
listener $cert_port 127.0.0.1
cafile $dir/ca.crt
certfile $dir/server.crt
keyfile $dir/server.key
tls_version tlsv1.2
require_certificate true
use_identity_as_username true
CONF
fi
