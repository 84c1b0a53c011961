#!/usr/bin/python3
"""A fleet-side subscriber for the uplink tests, written with python3-paho-mqtt (not rutd's code): connects
over TLS as the fleet reader with a persistent session (clean_session false: QoS 1 messages published while
it is away, a broker restart included, are kept for it), subscribes to TOPIC with QoS 1 and appends every
message to OUT as one JSON line {"topic", "retain", "payload"} (payload parsed when it is JSON, else the
text). Reconnects by itself; runs until SIGTERM.

Usage: subscribe.py HOST PORT CA_FILE USER PASSWORD TOPIC OUT [CLIENT_ID]
"""
import json
import signal
import sys
import time

import paho.mqtt.client as mqtt


def main(host, port, ca, user, password, topic, out_path, client_id="fleet-test"):
    out = open(out_path, "a", buffering=1)
    client = mqtt.Client(client_id=client_id, clean_session=False, protocol=mqtt.MQTTv311)
    client.username_pw_set(user, password)
    client.tls_set(ca_certs=ca)
    client.reconnect_delay_set(min_delay=1, max_delay=2)

    # Each connection event with its time and what the broker said (the session it kept, the QoS it
    # granted): a test that finds too few messages prints this log, and it tells whether this side came
    # back after an outage and found its session.
    def log(text):
        print(f"{time.time():.3f} {text}", file=sys.stderr, flush=True)

    def on_connect(c, userdata, flags, rc):
        if rc == 0:
            c.subscribe(topic, qos=1)
        log(f"connected rc={rc} session_present={flags.get('session present', '?')}")

    def on_subscribe(c, userdata, mid, granted_qos):
        log(f"subscribed mid={mid} granted_qos={list(granted_qos)}")

    def on_disconnect(c, userdata, rc):
        log(f"disconnected rc={rc}")

    def on_connect_fail(c, userdata):
        log("connection failed")

    def on_message(c, userdata, msg):
        text = msg.payload.decode("utf-8", "replace")
        try:
            payload = json.loads(text)
        except ValueError:
            payload = text
        out.write(json.dumps({"topic": msg.topic, "retain": bool(msg.retain), "payload": payload}) + "\n")

    client.on_connect = on_connect
    client.on_message = on_message
    client.on_subscribe = on_subscribe
    client.on_disconnect = on_disconnect
    client.on_connect_fail = on_connect_fail
    signal.signal(signal.SIGTERM, lambda *a: client.disconnect())
    client.connect_async(host, int(port), keepalive=10)
    client.loop_forever(retry_first_connection=True)


if __name__ == "__main__":
    if len(sys.argv) < 8:
        print(__doc__, file=sys.stderr)
        sys.exit(64)
    main(*sys.argv[1:])
