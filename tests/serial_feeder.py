#!/usr/bin/env python3
"""A text-line IMU on a pseudo-terminal, for the console test.

Usage: serial_feeder.py LINK RATE_HZ T0

Creates a pseudo-terminal reached through the symlink LINK (as a
/dev/serial/by-id/ link is) and writes, in real time, RATE_HZ lines
"counter,x,y,z\\r\\n" of white noise (deg/s), the counter being the
samples since the wall-clock time T0 (seconds since the epoch: a device
plugged in again keeps the count it kept while unplugged). A
SIGSTOP makes the device silent (SIGCONT resumes it, the missed lines are
sent late, as a stalled device's buffer would); killing it pulls the cable
(the link goes away and the reader's next read fails). Only the standard
library."""
import os
import random
import signal
import sys
import time
import tty


def main():
    link, rate, epoch = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
    counter = max(0, int((time.time() - epoch) * rate))
    master, slave = os.openpty()
    tty.setraw(master)
    name = os.ttyname(slave)
    os.close(slave)
    try:
        os.remove(link)
    except FileNotFoundError:
        pass
    os.symlink(name, link)

    def unplug(*_):
        try:
            os.remove(link)
        except FileNotFoundError:
            pass
        os._exit(0)

    signal.signal(signal.SIGTERM, unplug)
    signal.signal(signal.SIGINT, unplug)
    rng = random.Random(counter)
    t0 = time.monotonic()
    sent = 0
    while True:
        due = int((time.monotonic() - t0) * rate)
        lines = []
        while sent < due:
            k = counter + sent
            lines.append("%d,%.6f,%.6f,%.6f\r\n" % (k, rng.gauss(0.01, 0.05),
                                                   rng.gauss(-0.02, 0.05), rng.gauss(0.0, 0.05)))
            sent += 1
        if lines:
            data = "".join(lines).encode()
            while data:
                try:
                    n = os.write(master, data)
                    data = data[n:]
                except BlockingIOError:
                    time.sleep(0.005)
        time.sleep(0.01)


if __name__ == "__main__":
    main()
