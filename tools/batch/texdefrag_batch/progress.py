"""A one-line progress bar with counts and ETA on a terminal (standard error); silent otherwise."""

import sys
import time


def fmt_duration(s):
    if s is None:
        return "?"
    s = int(round(s))
    if s >= 3600:
        return f"{s // 3600}h{s % 3600 // 60:02d}m"
    if s >= 60:
        return f"{s // 60}m{s % 60:02d}s"
    return f"{s}s"


class Progress:
    def __init__(self, total, enabled=None, stream=sys.stderr):
        self.total, self.stream = total, stream
        self.enabled = stream.isatty() if enabled is None else enabled
        self.t0 = time.monotonic()
        self.last = 0.0

    def eta(self, ended_now, remaining):
        """Remaining time at the throughput of this batch so far; None before the first end."""
        if ended_now == 0:
            return None
        return (time.monotonic() - self.t0) / ended_now * remaining

    def update(self, finished, failed, running, ended_now, force=False):
        if not self.enabled:
            return
        now = time.monotonic()
        if not force and now - self.last < 0.2:
            return
        self.last = now
        done = finished + failed
        width = 30
        fill = int(width * done / self.total) if self.total else width
        line = (f"\r[{'#' * fill}{' ' * (width - fill)}] {done}/{self.total} ({finished} finished, {failed} failed,"
                f" {running} running) elapsed {fmt_duration(now - self.t0)} ETA "
                f"{fmt_duration(self.eta(ended_now, self.total - done))}")
        self.stream.write(line.ljust(110)[:140])
        self.stream.flush()

    def end(self):
        if self.enabled:
            self.stream.write("\r" + " " * 140 + "\r")
            self.stream.flush()
