"""Drive `motionctl grbl --pty` with a third-party grbl sender library, unmodified.

Usage: grbl_sender.py [--no-jog] [--no-hold] PORT GCODE_FILE EXPECTED_X EXPECTED_Y EXPECTED_Z [GCODE_FILE X Y Z ...]

grbl-streamer (pinned 2.0.2 by the caller) connects (it soft-resets and waits for the welcome),
reads the settings, homes, and streams each GCODE_FILE with character counting from machine
zero (the first one meanwhile gets a feed hold and a resume, and a feed override; before each
later one the library soft-resets and rapids back to machine zero), then a jog and a jog cancel,
and a final soft reset (`--no-jog` leaves the jog out, `--no-hold` the hold, resume and
override). Every line the library sends must be answered `ok` (the library's own
callbacks count them, per file), and the machine must end each file where its program ends
(EXPECTED_*, mm).

The library's preprocessor comments out G-codes grbl lacks (its whitelist is grbl 1.1's); the
bridge runs canned cycles and cutter compensation, so G40..G42 and G80..G89 are added to that
whitelist, and those lines reach the bridge as written.

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
        self.gate = threading.Lock()
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
        self.hash_updates = 0
        self.processed_lines = []
        self.writes = 0
        self.answers = 0
        self.state_log = []

    def callback(self, event, *data):
        if event == "on_processed_command":
            # The reader thread is about to stream more: not while `job_run` streams (gate).
            with self.gate:
                pass
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
                self.answers += 1
            elif event == "on_write":
                # Lines get an answer; real-time bytes (`!`, `~`) do not.
                if data[0].endswith("\n"):
                    self.writes += 1
            elif event == "on_rx_buffer_percent":
                # The library's callback on every `ok`, and once at each boot.
                self.answers += 1
            elif event == "on_alarm":
                self.alarms.append(data[0])
            elif event == "on_processed_command":
                self.processed += 1
                self.processed_lines.append(data)
            elif event == "on_line_sent":
                self.sent += 1
            elif event == "on_stateupdate":
                self.state = data[0]
                self.mpos = data[1]
                self.states_seen.add(data[0])
                self.state_log.append(data[0])
            elif event == "on_job_completed":
                self.job_completed += 1
            elif event == "on_hash_stateupdate":
                self.hash_updates += 1


def wait(what, pred, timeout):
    end = time.time() + timeout
    while time.time() < end:
        if pred():
            return
        time.sleep(0.02)
    raise SystemExit("timeout waiting for " + what)


def quiet(g, log):
    """Waits until every line the library wrote has its answer and it has nothing queued.

    The library streams from two threads (`job_run` in the caller's, each `ok` in its reader's)
    without a lock between them: an `ok` arriving while `job_run` fills the buffer can send a
    line twice and skip another (the bridge answers within a millisecond, far sooner than a
    grbl at 115200 baud). So `job_run` holds the log's gate, which the reader thread passes
    through before it streams on (the callback of each acknowledged line), and a job starts
    only once every earlier line (the library's own `$G` after each Idle, `$#` after the
    welcome, a `send_immediately`) has its answer, so no stray `ok` counts as the job's.
    """
    settled = 0
    end = time.time() + 10
    while settled < 3:
        if time.time() > end:
            raise SystemExit(
                "timeout waiting for the library's lines to be answered (%d written, %d answered)"
                % (log.writes, log.answers - log.boots)
            )
        with log.lock:
            idle = (
                log.writes == log.answers - log.boots
                and not g.gcode_parser_state_requested
                and not g.hash_state_requested
            )
        settled = settled + 1 if idle else 0
        time.sleep(g.poll_interval)


def main():
    args = sys.argv[1:]
    jog = "--no-jog" not in args
    hold = "--no-hold" not in args
    args = [a for a in args if a not in ("--no-jog", "--no-hold")]
    if not args:
        raise SystemExit("usage: grbl_sender.py [--no-jog] [--no-hold] PORT (GCODE_FILE X Y Z)...")
    port = args[0]
    rest = args[1:]
    if not rest or len(rest) % 4:
        raise SystemExit("usage: grbl_sender.py PORT (GCODE_FILE X Y Z)...")
    jobs = [
        (rest[i], tuple(float(v) for v in rest[i + 1 : i + 4])) for i in range(0, len(rest), 4)
    ]
    log = Log()
    g = GrblStreamer(log.callback)
    g.preprocessor.whitelist_commands["G"].extend([40, 41, 42] + list(range(80, 90)))
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

    results = []
    for n, (gcode, expected) in enumerate(jobs):
        if n > 0:
            # A fresh parser (the files leave G20/G91 behind), then machine zero.
            boots, hashes = log.boots, log.hash_updates
            g.softreset()
            wait("the welcome before " + gcode, lambda: log.boots > boots, 10)
            # The library asks for `$#` after the welcome; grbl refuses it during motion.
            wait("the library's $# after the welcome", lambda: log.hash_updates > hashes, 10)
            wait("Idle before " + gcode, lambda: log.state == "Idle", 10)
            g.send_immediately("G53 G0 Z0")
            wait("Z at zero", lambda: log.state == "Idle" and abs(log.mpos[2]) < 1e-6, 20)
            g.send_immediately("G53 G0 X0 Y0")
            wait(
                "machine zero before " + gcode,
                lambda: log.state == "Idle" and all(abs(v) < 1e-6 for v in log.mpos),
                20,
            )
        quiet(g, log)
        g.job_new()
        g.load_file(gcode)
        total = g.buffer_size
        completed = log.job_completed
        processed = log.processed
        errors = len(log.errors)
        since = len(log.state_log)
        with log.gate:
            g.job_run()
        if n == 0 and hold:
            wait("the job to run", lambda: log.state == "Run", 10)
            time.sleep(0.5)
            g.hold()
            wait("Hold:0", lambda: log.state == "Hold:0", 10)
            held_at = log.mpos
            time.sleep(0.5)
            assert log.mpos == held_at, (held_at, log.mpos)
            g.resume()
            wait("Run after resume", lambda: log.state == "Run", 10)
            # Feed override +10 % twice (0x91) for a while, then back to 100 % (0x90).
            os.write(raw, b"\x91\x91")
            time.sleep(0.5)
            os.write(raw, b"\x90")
        wait(
            gcode + " to finish",
            lambda: log.job_completed > completed
            and "Run" in log.state_log[since:]
            and log.state == "Idle",
            120,
        )
        end = log.mpos
        # Every line of the file acknowledged: the library's own record, by line number.
        acked = len({ln for ln, _ in log.processed_lines[processed:]} & set(range(total)))
        ok = (
            all(abs(e - a) < 0.0015 for e, a in zip(expected, end))
            and acked == total
            and len(log.errors) == errors
        )
        results.append((os.path.basename(gcode), ok, total, acked, end, expected))
        if os.environ.get("GRBL_SENDER_DEBUG"):
            seen = {ln for ln, _ in log.processed_lines[processed:]}
            print(gcode, "not acknowledged:", sorted(set(range(total)) - seen), file=sys.stderr)
    job_ok = all(r[1] for r in results)

    # Jog and cancel it: the machine stops short of the target.
    jogged, jog_ok = 0.0, True
    if jog:
        start = log.mpos
        if os.environ.get("GRBL_SENDER_DEBUG"):
            print("before jog:", log.state, g._rx_buffer_fill, log.reads[-5:], file=sys.stderr)
        g.send_immediately("$J=G21 G91 X50 F600")
        wait("Jog", lambda: log.state == "Jog", 10)
        # Cancel once the machine is seen moving, not after a fixed time: on a loaded machine
        # QEMU can take longer than any fixed pause to start the jog, and a cancel before the
        # first step rightly moves nothing.
        wait("the jog's first motion", lambda: log.mpos[0] > start[0], 20)
        time.sleep(0.2)
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

    held = "Hold:0" in log.states_seen or not hold
    ok = job_ok and jog_ok and not log.errors and not log.alarms and held
    for name, file_ok, total, acked, end, expected in results:
        print(
            "FILE %s ok=%d lines=%d acked=%d end=%s expected=%s"
            % (
                name,
                file_ok,
                total,
                acked,
                ",".join("%.3f" % v for v in end),
                ",".join("%.3f" % v for v in expected),
            )
        )
    print(
        "RESULT ok=%d files=%d sent=%d processed=%d errors=%d alarms=%d jogged=%.3f states=%s"
        % (
            ok,
            len(results),
            log.sent,
            log.processed,
            len(log.errors),
            len(log.alarms),
            jogged,
            "/".join(sorted(log.states_seen)),
        )
    )
    if log.errors:
        print("errors:", log.errors[:5])
    return 0 if ok else 1


if __name__ == "__main__":
    # The library's threads keep the process alive after an exception: exit hard.
    try:
        code = main()
    except BaseException as e:
        print("FAILED: %s" % (e,), flush=True)
        code = 1
    sys.stdout.flush()
    os._exit(code)
