// Per-frame measurement: being written.
