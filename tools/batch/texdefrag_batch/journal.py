"""The batch journal (SQLite, OUT/.texdefrag-batch/journal.sqlite) and the output folder's lock.

The journal is the single record of a production's batch: only the client process writes it, one
transaction per event, so a crash of the client loses at most the attempts that were running (they
stay "running" and are redone by the next batch). Schema (docs/batch.md):

  tasks(id PRIMARY KEY, input, output_dir, input_hash, config_hash, files, status, attempts, error,
        started_at, finished_at, wall_s, host, outputs, figures)
      status: running | finished | failed; files: JSON [[path, size, mtime_ns], ...] of the
      inputs hashed (a cache: unchanged stats => unchanged hash); outputs: JSON [relative path...]
      under the output folder; figures: JSON of the run report figures.
  attempts(task_id, batch_id, attempt, status, error, started_at, finished_at, wall_s, host,
           exit_code, signal, max_rss_kb)   one row per attempt that ended, in order
  batches(id, started_at, finished_at, argv, host, pid, counts)
  meta(key, value)                          schema version
"""

import fcntl
import json
import os
import socket
import sqlite3
import time

SCHEMA_VERSION = "1"
STATE_DIR = ".texdefrag-batch"


class JournalError(Exception):
    """The journal cannot be used; the message names the file and the cause."""


class LockError(Exception):
    """Another batch holds the output folder."""


SCHEMA = """
CREATE TABLE IF NOT EXISTS meta(key TEXT PRIMARY KEY, value TEXT);
CREATE TABLE IF NOT EXISTS tasks(
  id TEXT PRIMARY KEY, input TEXT NOT NULL, output_dir TEXT NOT NULL,
  input_hash TEXT, config_hash TEXT, files TEXT,
  status TEXT NOT NULL, attempts INTEGER NOT NULL DEFAULT 0, error TEXT,
  started_at REAL, finished_at REAL, wall_s REAL, host TEXT, outputs TEXT, figures TEXT);
CREATE TABLE IF NOT EXISTS attempts(
  task_id TEXT NOT NULL, batch_id INTEGER, attempt INTEGER, status TEXT NOT NULL, error TEXT,
  started_at REAL, finished_at REAL, wall_s REAL, host TEXT, exit_code INTEGER, signal INTEGER,
  max_rss_kb INTEGER);
CREATE TABLE IF NOT EXISTS batches(
  id INTEGER PRIMARY KEY, started_at REAL, finished_at REAL, argv TEXT, host TEXT, pid INTEGER,
  counts TEXT);
"""

TASK_COLUMNS = ("id", "input", "output_dir", "input_hash", "config_hash", "files", "status", "attempts",
                "error", "started_at", "finished_at", "wall_s", "host", "outputs", "figures")


class Lock:
    """An exclusive flock on OUT/.texdefrag-batch/lock, held for the batch's lifetime (released by the
    kernel when the process dies, so a crashed batch never leaves a stale lock). The file says who
    holds it."""

    def __init__(self, state_dir):
        self.path = os.path.join(state_dir, "lock")
        self.fd = None

    def acquire(self, argv):
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            try:
                holder = os.read(fd, 4096).decode("utf-8", "replace").strip()
            finally:
                os.close(fd)
            raise LockError(f"another batch is running on this output folder (lock {self.path} held by: "
                            f"{holder or 'unknown'}); wait for it to end or stop it") from None
        os.ftruncate(fd, 0)
        info = {"host": socket.gethostname(), "pid": os.getpid(),
                "since": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "argv": argv}
        os.write(fd, (json.dumps(info) + "\n").encode())
        self.fd = fd

    def release(self):
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None


class Journal:
    """Access to journal.sqlite. Every method commits before returning."""

    def __init__(self, path):
        self.path = path
        try:
            self.db = sqlite3.connect(path, isolation_level=None, timeout=30)
            self.db.execute("PRAGMA synchronous=FULL")
            version = None
            has_meta = self.db.execute(
                "SELECT count(*) FROM sqlite_master WHERE type='table' AND name='meta'").fetchone()[0]
            if has_meta:
                row = self.db.execute("SELECT value FROM meta WHERE key='schema_version'").fetchone()
                version = row[0] if row else None
                if version != SCHEMA_VERSION:
                    raise JournalError(f"{path}: journal schema version {version!r}, this texdefrag writes "
                                       f"{SCHEMA_VERSION!r}; move it aside to start a new journal")
            with self.db:
                self.db.execute("BEGIN")
                for statement in SCHEMA.split(";"):
                    if statement.strip():
                        self.db.execute(statement)
                self.db.execute("INSERT OR IGNORE INTO meta VALUES('schema_version', ?)", (SCHEMA_VERSION,))
            # A full read proves the file is whole (a truncated or overwritten file fails here).
            self.db.execute("SELECT count(*), max(length(outputs)) FROM tasks").fetchone()
            self.db.execute("SELECT count(*) FROM attempts").fetchone()
        except sqlite3.DatabaseError as e:
            raise JournalError(f"{path}: unreadable journal ({e}); nothing was changed. Move it aside to "
                               "start a new journal: finished outputs stay in place and are redone "
                               "(not lost) only if they are not recorded") from None

    def close(self):
        self.db.close()

    def _tx(self, sql, args=()):
        with self.db:
            self.db.execute("BEGIN IMMEDIATE")
            return self.db.execute(sql, args)

    def tasks(self):
        """All task rows as dicts, keyed by id."""
        cur = self.db.execute(f"SELECT {', '.join(TASK_COLUMNS)} FROM tasks")
        out = {}
        for row in cur.fetchall():
            d = dict(zip(TASK_COLUMNS, row))
            for k in ("files", "outputs", "figures"):
                d[k] = json.loads(d[k]) if d[k] else None
            out[d["id"]] = d
        return out

    def attempts(self, task_id=None):
        cols = ("task_id", "batch_id", "attempt", "status", "error", "started_at", "finished_at", "wall_s",
                "host", "exit_code", "signal", "max_rss_kb")
        sql = f"SELECT {', '.join(cols)} FROM attempts"
        rows = self.db.execute(sql + (" WHERE task_id=?" if task_id else "") + " ORDER BY rowid",
                               (task_id,) if task_id else ()).fetchall()
        return [dict(zip(cols, r)) for r in rows]

    def begin_batch(self, argv):
        cur = self._tx("INSERT INTO batches(started_at, argv, host, pid) VALUES(?,?,?,?)",
                       (time.time(), json.dumps(argv), socket.gethostname(), os.getpid()))
        return cur.lastrowid

    def end_batch(self, batch_id, counts):
        self._tx("UPDATE batches SET finished_at=?, counts=? WHERE id=?", (time.time(), json.dumps(counts), batch_id))

    def start_task(self, task, input_hash, config_hash, files, reset_attempts):
        """Marks a task running (creating its row); attempts restart at 0 when reset_attempts."""
        self._tx("""INSERT INTO tasks(id, input, output_dir, input_hash, config_hash, files, status, attempts,
                      started_at) VALUES(?,?,?,?,?,?, 'running', 0, ?)
                    ON CONFLICT(id) DO UPDATE SET input=excluded.input, output_dir=excluded.output_dir,
                      input_hash=excluded.input_hash, config_hash=excluded.config_hash, files=excluded.files,
                      status='running', error=NULL, started_at=excluded.started_at,
                      attempts=CASE WHEN ? THEN 0 ELSE tasks.attempts END""",
                 (task["id"], task["input"], task["output_dir"], input_hash, config_hash, json.dumps(files),
                  time.time(), 1 if reset_attempts else 0))

    def end_attempt(self, task_id, batch_id, result, outputs=None, fail_error=None):
        """Records one ended attempt, in the same transaction: the task finished (outputs given: the
        attempt succeeded and its outputs are in place) or failed for good (fail_error given), else
        still running (it will be retried). Returns the task's attempt count."""
        ok = outputs is not None
        with self.db:
            self.db.execute("BEGIN IMMEDIATE")
            n = self.db.execute("SELECT attempts FROM tasks WHERE id=?", (task_id,)).fetchone()[0] + 1
            self.db.execute("UPDATE tasks SET attempts=? WHERE id=?", (n, task_id))
            self.db.execute("""INSERT INTO attempts(task_id, batch_id, attempt, status, error, started_at,
                                 finished_at, wall_s, host, exit_code, signal, max_rss_kb)
                               VALUES(?,?,?,?,?,?,?,?,?,?,?,?)""",
                            (task_id, batch_id, n, "finished" if ok else result["status"],
                             result.get("error"), result.get("started_at"), result.get("finished_at"),
                             result.get("wall_s"), result.get("host"), result.get("exit_code"),
                             result.get("signal"), result.get("max_rss_kb")))
            if ok:
                figures = dict(result.get("figures") or {})
                figures["max_rss_kb"] = result.get("max_rss_kb")
                figures["cpu_s"] = result.get("cpu_s")
                self.db.execute("""UPDATE tasks SET status='finished', error=NULL, finished_at=?, wall_s=?, host=?,
                                     outputs=?, figures=? WHERE id=?""",
                                (result.get("finished_at") or time.time(), result.get("wall_s"), result.get("host"),
                                 json.dumps(outputs), json.dumps(figures), task_id))
            elif fail_error is not None:
                self.db.execute("""UPDATE tasks SET status='failed', error=?, finished_at=?, wall_s=?, host=?
                                   WHERE id=?""",
                                (fail_error, result.get("finished_at") or time.time(), result.get("wall_s"),
                                 result.get("host"), task_id))
        return n

    def outputs(self, task_id):
        row = self.db.execute("SELECT outputs FROM tasks WHERE id=?", (task_id,)).fetchone()
        return json.loads(row[0]) if row and row[0] else []

    def attempt_count(self, task_id):
        return self.db.execute("SELECT attempts FROM tasks WHERE id=?", (task_id,)).fetchone()[0]

    def fail_unstarted(self, task, error):
        """A task that cannot start (its tile file is missing): failed, with the error. A finished
        record keeps its outputs listed (they stay on disk); only the status and error change."""
        self._tx("""INSERT INTO tasks(id, input, output_dir, status, attempts, error, finished_at)
                    VALUES(?,?,?, 'failed', 0, ?, ?)
                    ON CONFLICT(id) DO UPDATE SET status='failed', error=excluded.error,
                      finished_at=excluded.finished_at""",
                 (task["id"], task["input"], task["output_dir"], error, time.time()))
