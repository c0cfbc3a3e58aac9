"""Where attempts run: local processes (-j N) or a Dask distributed cluster (--scheduler).

Both offer submit(key, spec) and next_done() -> (key, result); a result is runner.run_attempt's
dict. Neither touches the journal: the client does, in the order results arrive.
"""

import concurrent.futures
import os
import time

from . import runner


class ExecutorError(Exception):
    """The executor cannot start (scheduler unreachable, no worker, paths not shared)."""


class LocalExecutor:
    """N threads, each supervising one texdefrag child process at a time."""

    def __init__(self, jobs):
        self.pool = concurrent.futures.ThreadPoolExecutor(max_workers=jobs)
        self.pending = {}
        self.slots = jobs

    def describe(self):
        return f"{self.slots} local process(es)"

    def submit(self, key, spec):
        self.pending[self.pool.submit(runner.run_attempt, spec)] = key

    def running(self):
        return len(self.pending)

    def next_done(self, timeout=None):
        done, _ = concurrent.futures.wait(list(self.pending), timeout=timeout,
                                          return_when=concurrent.futures.FIRST_COMPLETED)
        if not done:
            return None
        fut = next(iter(done))
        key = self.pending.pop(fut)
        return key, fut.result()

    def close(self, cancel=False):
        self.pool.shutdown(wait=not cancel, cancel_futures=cancel)


class DaskExecutor:
    """Attempts submitted to a Dask scheduler; each worker thread runs one texdefrag child.

    A worker lost in the middle of an attempt: the scheduler reruns the attempt on another worker
    (up to its allowed-failures, then KilledWorker, recorded here as a failed attempt). Only the
    result delivered to the client counts; a rerun writes into a new staging folder.
    """

    def __init__(self, address, connect_timeout, check_paths):
        try:
            import cloudpickle
            import distributed
        except ImportError as e:
            raise ExecutorError(f"--scheduler needs Dask distributed for this Python ({e}); "
                                "Debian: apt install python3-distributed") from None
        # Workers need only the executable and the storage, not this package.
        cloudpickle.register_pickle_by_value(runner)
        self.distributed = distributed
        try:
            self.client = distributed.Client(address, timeout=connect_timeout, set_as_default=False)
        except (OSError, TimeoutError, ValueError) as e:
            raise ExecutorError(f"cannot reach the Dask scheduler at {address} "
                                f"(waited {connect_timeout:g} s): {e}") from None
        self.address = address
        self.connect_timeout = connect_timeout
        try:
            self.client.wait_for_workers(1, timeout=connect_timeout)
        except (TimeoutError, OSError) as e:
            self.client.close()
            raise ExecutorError(f"the Dask scheduler at {address} has no worker after {connect_timeout:g} s "
                                f"({e}); start dask-worker {address} on the machines (docs/batch.md)") from None
        self._check(check_paths)
        self.pending = {}
        self.lost_since = None

    def _check(self, paths):
        """Every connected worker must see the executable, the configuration and the output folder."""
        try:
            answers = self.client.run(runner.probe, paths)
        except Exception as e:  # noqa: BLE001 (any worker failure is reported as such)
            raise ExecutorError(f"cannot check the workers of {self.address}: {e}") from None
        bad = [f"worker {w} on host {a['host']}: missing {', '.join(f'{k} {p}' for k, p in a['missing'].items())}"
               for w, a in answers.items() if a["missing"]]
        if bad:
            self.client.close()
            raise ExecutorError("workers that do not see the shared storage at the client's paths:\n  "
                                + "\n  ".join(bad))

    def describe(self):
        info = self.client.scheduler_info()
        threads = sum(w.get("nthreads", 0) for w in info.get("workers", {}).values())
        return f"Dask scheduler {self.address} ({len(info.get('workers', {}))} worker(s), {threads} thread(s))"

    def submit(self, key, spec):
        # pure=False: each attempt is new work even with the same arguments; one key per attempt.
        self._check_scheduler()
        fut = self.client.submit(runner.run_attempt, spec, key=f"texdefrag-{os.path.basename(spec['staging'])}",
                                 pure=False, retries=0)
        self.pending[fut.key] = (key, fut, spec)

    def running(self):
        return len(self.pending)

    def _check_scheduler(self, cancelled=False):
        """Raises ExecutorError when the scheduler is lost: the client closed, or disconnected and
        either its attempts were cancelled by the disconnection or it has not reconnected within
        the connect timeout. The attempts then still running are left `running` in the journal (the
        next batch redoes them as interrupted); none is recorded as failed for the loss."""
        status = str(getattr(self.client, "status", "running"))
        if status == "running":
            self.lost_since = None
            return
        now = time.monotonic()
        self.lost_since = self.lost_since or now
        if cancelled or status in ("closing", "closed", "failed") or now - self.lost_since > self.connect_timeout:
            raise ExecutorError(
                f"lost the Dask scheduler at {self.address} in the middle of the batch (client {status}, "
                f"{len(self.pending)} attempt(s) running): finished tasks are recorded; run the same command again "
                "with a running scheduler, or without --scheduler, to finish the rest")

    def next_done(self, timeout=None):
        self._check_scheduler()
        if not self.pending:
            return None
        # note: polled (Future.done reads the client's local state), not distributed.wait, which
        # needs a default client and blocks on the event loop of a client that may have lost its scheduler.
        deadline = time.monotonic() + (timeout or 0)
        while True:
            done = [f for _, f, _ in self.pending.values() if f.done()]
            if done or time.monotonic() >= deadline:
                break
            time.sleep(0.05)
        if not done:
            return None
        fut = sorted(done, key=lambda f: f.key)[0]
        if fut.status == "cancelled":
            self._check_scheduler(cancelled=True)
        key, _, spec = self.pending.pop(fut.key)
        try:
            return key, fut.result()
        except self.distributed.KilledWorker as e:
            error = f"the worker running it died repeatedly (Dask KilledWorker: {e})"
        except Exception as e:  # noqa: BLE001 (a lost scheduler or a cancelled future is recorded)
            error = f"Dask: {type(e).__name__}: {e}"
        finally:
            fut.release()
        return key, {"status": "crashed", "error": error, "host": None, "files": [], "figures": {},
                     "staging": spec["staging"]}

    def close(self, cancel=False):
        """Disconnects; with cancel, first asks the scheduler to drop this batch's attempts. Never
        raises (it runs on the way out of an interrupt or a lost scheduler)."""
        try:
            if cancel and self.pending:
                self.client.cancel([fut for _, fut, _ in self.pending.values()], force=True)
        except Exception:  # noqa: BLE001
            pass
        try:
            self.client.close(timeout=10)
        except Exception:  # noqa: BLE001
            pass
