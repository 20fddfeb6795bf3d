#!/usr/bin/env python3
"""Captures the RTPS frames on a network interface (raw AF_PACKET socket, needs root; frames holding the "RTPS"
magic) into a file, for SECONDS or until SIGTERM; then `capture.py find FILE FIRST LAST PERIOD` counts how many
of the sensor samples' times t = k * PERIOD (k in FIRST..LAST, IEEE 754 little-endian doubles, as the world
writes them) appear in it. Times with a short binary mantissa (1.0, 1.125, 1.25, ...: k a multiple of 125 for
a 1 ms period) are left out: such doubles also occur in other fields."""
import signal
import socket
import struct
import sys
import time


def capture(iface, out, seconds):
    s = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(0x0003))
    s.bind((iface, 0))
    s.settimeout(0.2)
    stop = [False]
    signal.signal(signal.SIGTERM, lambda *_: stop.__setitem__(0, True))
    end = time.time() + seconds
    n = 0
    with open(out, "wb") as f:
        while not stop[0] and time.time() < end:
            try:
                frame = s.recv(65535)
            except socket.timeout:
                continue
            if b"RTPS" in frame:
                f.write(frame)
                n += 1
    print(f"rtps_frames={n}")


def find(path, first, last, period):
    data = open(path, "rb").read()
    ks = [k for k in range(first, last + 1) if k % 125 != 0]
    hits = sum(1 for k in ks if struct.pack("<d", k * period) in data)
    print(f"bytes={len(data)} sensor_times_found={hits} of {len(ks)}")


if __name__ == "__main__":
    if len(sys.argv) == 5 and sys.argv[1] == "capture":
        capture(sys.argv[2], sys.argv[3], float(sys.argv[4]))
    elif len(sys.argv) == 6 and sys.argv[1] == "find":
        find(sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), float(sys.argv[5]))
    else:
        sys.exit("usage: capture.py capture IFACE OUT SECONDS | capture.py find FILE FIRST LAST PERIOD")
