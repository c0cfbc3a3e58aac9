"""Where attempts run: local processes (-j N) or a Dask distributed cluster (--scheduler).

Both offer submit(key, spec) and next_done() -> (key, result); a result is runner.run_attempt's
dict. Neither touches the journal: the client does, in the order results arrive.
"""

import concurrent.futures
import os

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
        try:
            self.client.wait_for_workers(1, timeout=connect_timeout)
        except (TimeoutError, OSError) as e:
            self.client.close()
            raise ExecutorError(f"the Dask scheduler at {address} has no worker after {connect_timeout:g} s "
                                f"({e}); start dask-worker {address} on the machines (docs/batch.md)") from None
        self._check(check_paths)
        self.ac = distributed.as_completed([], loop=self.client.loop, with_results=False)
        self.pending = {}

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
        fut = self.client.submit(runner.run_attempt, spec, key=f"texdefrag-{os.path.basename(spec['staging'])}",
                                 pure=False, retries=0)
        self.pending[fut.key] = (key, fut, spec)
        self.ac.add(fut)

    def running(self):
        return len(self.pending)

    def next_done(self, timeout=None):
        try:
            fut = next(self.ac)
        except StopIteration:
            return None
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
