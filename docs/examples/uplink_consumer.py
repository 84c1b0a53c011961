#!/usr/bin/python3
"""A fleet-side consumer of rutd's uplink (docs/uplink.md), in the few lines a data platform needs: subscribe
to every vehicle with QoS 1 and a persistent session, drop duplicates by (vehicle, id), and print each
segment's advisory. python3-paho-mqtt (Debian) and, for the check, python3-jsonschema.

    uplink_consumer.py broker.example 8883 ca.crt fleet PASSWORD
"""
import json
import sys

import paho.mqtt.client as mqtt

seen = {}  # vehicle -> ids already handled (a real consumer keeps the highest contiguous id and a window)


def on_message(client, userdata, msg):
    m = json.loads(msg.payload)
    if m["type"] == "status":
        print(f"{m['vehicle']}: {m['state']}")
        return
    ids = seen.setdefault(m["vehicle"], set())
    if m["id"] in ids:
        return  # at-least-once: a repeated id is the same message again
    ids.add(m["id"])
    if m["type"] == "segment":
        print(f"{m['vehicle']} #{m['id']} {m['start_m']:.0f}-{m['end_m']:.0f} m: {m['advisory']}, "
              f"P95 {m['p95_depth_mm']} mm, position {m['position']}")


host, port, ca, user, password = sys.argv[1:6]
client = mqtt.Client(client_id="fleet-consumer", clean_session=False)
client.username_pw_set(user, password)
client.tls_set(ca_certs=ca)
client.on_connect = lambda c, u, f, rc: c.subscribe("rutd/#", qos=1)
client.on_message = on_message
client.connect(host, int(port))
client.loop_forever()
