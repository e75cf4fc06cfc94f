"""Drive `motionctl grbl --pty` with a third-party grbl sender library, unmodified.

Usage: grbl_sender.py PORT GCODE_FILE EXPECTED_X EXPECTED_Y EXPECTED_Z

grbl-streamer (pinned 2.0.2 by the caller) connects (it soft-resets and waits for the welcome),
reads the settings, homes, streams GCODE_FILE with character counting, and meanwhile gets a
feed hold and a resume, a feed override, then a jog and a jog cancel, and a final soft reset.
Every line the library sends must be answered `ok` (the library's own callbacks count them),
and the machine must end where the file's program ends (EXPECTED_*, mm).

grbl-streamer writes str encoded as ASCII, so it cannot send grbl's extended real-time bytes
(0x80..0xFF: overrides, jog cancel); those go through a second, write-only descriptor of the
same port, as a second program on the same serial port would send them.

Prints one `RESULT key=value ...` line and exits 0 when every check passed.
"""

import os
import re
import sys
import threading
import time

from grbl_streamer import GrblStreamer


class Log:
    def __init__(self):
        self.lock = threading.Lock()
        self.events = []
        self.reads = []
        self.errors = []
        self.alarms = []
        self.processed = 0
        self.sent = 0
        self.boots = 0
        self.settings = {}
        self.state = None
        self.mpos = None
        self.states_seen = set()
        self.job_completed = 0

    def callback(self, event, *data):
        with self.lock:
            if event == "on_boot":
                self.boots += 1
            elif event == "on_read":
                self.reads.append(data[0])
                m = re.match(r"^\$(\d+)=(.*)$", data[0])
                if m:
                    self.settings[int(m.group(1))] = m.group(2)
            elif event == "on_error":
                self.errors.append(data)
            elif event == "on_alarm":
                self.alarms.append(data[0])
            elif event == "on_processed_command":
                self.processed += 1
            elif event == "on_line_sent":
                self.sent += 1
            elif event == "on_stateupdate":
                self.state = data[0]
                self.mpos = data[1]
                self.states_seen.add(data[0])
            elif event == "on_job_completed":
                self.job_completed += 1


def wait(what, pred, timeout):
    end = time.time() + timeout
    while time.time() < end:
        if pred():
            return
        time.sleep(0.02)
    raise SystemExit("timeout waiting for " + what)


def main():
    port, gcode = sys.argv[1], sys.argv[2]
    expected = tuple(float(v) for v in sys.argv[3:6])
    log = Log()
    g = GrblStreamer(log.callback)
    if os.environ.get("GRBL_SENDER_DEBUG"):
        import logging

        h = logging.StreamHandler(sys.stderr)
        h.setLevel(logging.INFO)
        g.setup_logging(h)
    g.poll_interval = 0.05
    g.cnect(port, 115200)
    wait("the welcome", lambda: g.is_connected(), 10)
    g.poll_start()
    # The library asks for $$ on boot; the list ends with $132.
    wait("the settings", lambda: 132 in log.settings, 10)
    assert log.settings[100] == "80.000", log.settings
    assert log.settings[110] == "15000.000", log.settings
    assert log.settings[122] == "500.000", log.settings

    raw = os.open(port, os.O_WRONLY | os.O_NOCTTY)

    g.homing()
    wait("Idle after homing", lambda: log.state == "Idle", 10)

    g.load_file(gcode)
    total = g.buffer_size
    completed = log.job_completed
    g.job_run()
    wait("the job to run", lambda: log.state == "Run", 10)
    time.sleep(1.0)
    g.hold()
    wait("Hold:0", lambda: log.state == "Hold:0", 10)
    held_at = log.mpos
    time.sleep(0.5)
    assert log.mpos == held_at, (held_at, log.mpos)
    g.resume()
    wait("Run after resume", lambda: log.state == "Run", 10)
    # Feed override +10 % twice (0x91) for a while, then back to 100 % (0x90).
    os.write(raw, b"\x91\x91")
    time.sleep(1.0)
    os.write(raw, b"\x90")
    wait(
        "the job to finish",
        lambda: log.job_completed > completed and log.state == "Idle",
        300,
    )
    end = log.mpos
    job_ok = all(abs(e - a) < 0.0015 for e, a in zip(expected, end))

    # Jog and cancel it: the machine stops short of the target.
    start = log.mpos
    if os.environ.get("GRBL_SENDER_DEBUG"):
        print("before jog:", log.state, g._rx_buffer_fill, log.reads[-5:], file=sys.stderr)
    g.send_immediately("$J=G91 X50 F600")
    wait("Jog", lambda: log.state == "Jog", 10)
    time.sleep(0.4)
    os.write(raw, b"\x85")
    wait("Idle after jog cancel", lambda: log.state == "Idle", 10)
    jogged = log.mpos[0] - start[0]
    jog_ok = 0.0 < jogged < 50.0

    boots = log.boots
    g.softreset()
    wait("the welcome after a soft reset", lambda: log.boots > boots, 10)
    os.close(raw)
    g.poll_stop()
    g.disconnect()

    ok = (
        job_ok
        and jog_ok
        and not log.errors
        and not log.alarms
        and log.processed >= total
        and "Hold:0" in log.states_seen
    )
    print(
        "RESULT ok=%d lines=%d sent=%d processed=%d errors=%d alarms=%d end=%s expected=%s "
        "jogged=%.3f states=%s"
        % (
            ok,
            total,
            log.sent,
            log.processed,
            len(log.errors),
            len(log.alarms),
            ",".join("%.3f" % v for v in end),
            ",".join("%.3f" % v for v in expected),
            jogged,
            "/".join(sorted(log.states_seen)),
        )
    )
    if log.errors:
        print("errors:", log.errors[:5])
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
