"""Independent jobs (evaluation episodes) spread over local processes or a Ray cluster, results as they come.

`run_jobs(fn, jobs, workers=N)` runs `fn(*job)` for every job in N spawned processes
(`concurrent.futures.ProcessPoolExecutor`); `run_jobs(fn, jobs, ray_address=ADDRESS)` runs them as Ray tasks
on the cluster at ADDRESS ("local" starts a Ray instance on this machine, "auto" finds a running one). Both
yield `(index, result)` in completion order, so a caller keeps whatever has finished whatever happens later.

A job whose worker process dies is retried, and reported as a `JobFailed` once its retries are spent; a job
whose `fn` raises is reported at once (an episode is deterministic: it would raise again). Ray does the
retrying itself (`max_retries`). A local process pool cannot say which of its jobs killed a worker (the
whole pool breaks), so the jobs in flight at a death are run again one at a time: only a death while a job
runs alone is held against that job.

Workers use one torch thread (small MLPs are fastest on one; N workers must not fight over the cores).

Run as written from a script. Local workers start from a forkserver, which (as `spawn` does) runs the caller's main
script again in each worker, unless the script guards its work with `if __name__ == "__main__":`; unguarded, each
worker would start the whole run again. Where neither `fn` nor the jobs need anything defined in that script, the
workers are started without it (`_without_main_script`), so a script calling `run_jobs` (or `evaluate`, `run_suite`
with `workers`) runs as it is written, guard or not. Ctrl-C stops the run in the main process alone: the workers
ignore it and are ended there, with the jobs they had in hand (no traceback from each of them).
"""

from __future__ import annotations

import multiprocessing
import pickle
import signal
import sys
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

RETRIES = 2
"""Default reruns of a job whose worker died (on Ray: Ray's `max_retries`)."""
LOCAL = "local"
"""`--ray local`: start a Ray instance on this machine for the run."""


@dataclass(frozen=True)
class JobFailed:
    """A job that produced no result: why, and how many of its runs died."""

    error: str
    deaths: int
    """Runs of this job lost to a dead worker (0 when `fn` raised)."""


def _init_worker() -> None:
    """A local worker: one torch thread, and Ctrl-C left to the main process, which ends the workers itself."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    import torch

    torch.set_num_threads(1)


def _uses_main_script(fn: Callable[..., Any], jobs: Sequence[tuple]) -> bool:
    """Whether `fn` or the jobs refer to something defined in the main script (`__main__`), which the workers then
    need (pickle names each function and class it refers to by its module)."""
    try:
        return b"__main__" in pickle.dumps((fn, list(jobs)))
    except Exception:  # what does not pickle fails in the pool, and says why there
        return True


@contextmanager
def _without_main_script(hidden: bool) -> Iterator[None]:
    """While `hidden`, workers started here do not run the main script again: multiprocessing finds the script by
    the main module's `__file__` (or `__spec__`, under `python -m`), so both are set aside while they start."""
    main = sys.modules.get("__main__")
    if not hidden or main is None:
        yield
        return
    saved = {name: getattr(main, name) for name in ("__file__", "__spec__") if hasattr(main, name)}
    try:
        main.__spec__ = None
        if "__file__" in saved:
            del main.__file__
        yield
    finally:
        for name, value in saved.items():
            setattr(main, name, value)


def _end(pool: ProcessPoolExecutor) -> None:
    """Ends a pool's workers now, with the jobs they hold (on Ctrl-C, or when the caller stops reading): Python
    3.14's `terminate_workers`, or before it the same on the pool's processes."""
    if hasattr(pool, "terminate_workers"):
        pool.terminate_workers()
        return
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        process.terminate()
    pool.shutdown(wait=True, cancel_futures=True)


def _in_worker(fn: Callable[..., Any], *job: Any) -> Any:
    """`fn(*job)` in a Ray worker, with one torch thread."""
    _init_worker()
    return fn(*job)


def run_jobs(fn: Callable[..., Any], jobs: Sequence[tuple], *, workers: int = 1, ray_address: str | None = None,
             retries: int = RETRIES) -> Iterator[tuple[int, Any]]:
    """(index into `jobs`, fn(*job) or JobFailed), in completion order; Ray when `ray_address` is given.

    `fn` and the jobs must pickle (a module-level function and plain data). With Ray, an already started
    Ray session (`ray.init` by the caller) is used as it is; otherwise one is started at `ray_address`,
    with `workers` CPUs when it is local, and shut down at the end.
    """
    if retries < 0:
        raise ValueError(f"retries must be >= 0, got {retries}")
    if ray_address is not None:
        return _ray_jobs(fn, jobs, ray_address, workers, retries)
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    return _pool_jobs(fn, jobs, workers, retries)


def _pool_jobs(fn: Callable[..., Any], jobs: Sequence[tuple], workers: int,
               retries: int) -> Iterator[tuple[int, Any]]:
    todo, alone = deque(range(len(jobs))), deque()
    deaths = [0] * len(jobs)
    # Workers fork from a server that has imported `fn`'s module and nothing else: quick to start (a
    # broken pool is replaced at once), and no copy of this process's MuJoCo, torch or GL state.
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload([getattr(fn, "func", fn).__module__])
    no_main = not _uses_main_script(fn, jobs)
    while todo or alone:
        lane, size = (alone, 1) if alone else (todo, min(workers, len(todo)))
        pool = ProcessPoolExecutor(size, mp_context=context, initializer=_init_worker)
        ended = False
        try:
            running: dict[Any, int] = {}
            broken = False
            while (lane or running) and not broken:
                while lane and len(running) < size:
                    i = lane.popleft()
                    with _without_main_script(no_main):  # workers start on a submit
                        running[pool.submit(fn, *jobs[i])] = i
                done, _ = wait(running, return_when=FIRST_COMPLETED)
                if any(isinstance(f.exception(), BrokenProcessPool) for f in done):
                    broken = True
                    done, _ = wait(running)  # a broken pool fails every job it still held
                for future in done:
                    i = running.pop(future)
                    error = future.exception()
                    if error is None:
                        yield i, future.result()
                    elif not isinstance(error, BrokenProcessPool):
                        yield i, JobFailed(f"{type(error).__name__}: {error}", deaths[i])
                    elif size > 1:
                        alone.append(i)  # which job killed the worker is unknown: rerun each alone
                    else:
                        deaths[i] += 1
                        if deaths[i] > retries:
                            yield i, JobFailed(f"its worker process died {deaths[i]} times", deaths[i])
                        else:
                            alone.appendleft(i)
            ended = True
        finally:
            if ended:
                pool.shutdown(wait=True)
            else:  # Ctrl-C, or the caller closed this generator: end the workers rather than wait for them
                _end(pool)


RAY_MISSING = "Ray is not installed: it is an extra of auv-mj, pip install 'auv-mj[ray]' (or -e '.[ray]' in a checkout)"
"""What a job on Ray says where Ray is not installed."""


def require_ray() -> None:
    """ImportError naming the extra (RAY_MISSING) unless Ray can be imported."""
    try:
        import ray  # noqa: F401
    except ImportError:
        raise ImportError(RAY_MISSING) from None


def _ray_jobs(fn: Callable[..., Any], jobs: Sequence[tuple], address: str, workers: int,
              retries: int) -> Iterator[tuple[int, Any]]:
    require_ray()
    import ray
    from ray.exceptions import RayError, RayTaskError

    started_here = not ray.is_initialized()
    if started_here:
        if address == LOCAL:
            ray.init(num_cpus=workers if workers > 1 else None, include_dashboard=False)
        else:
            ray.init(address=address)
    try:
        remote = ray.remote(num_cpus=1, max_retries=retries)(_in_worker)
        pending = {remote.remote(fn, *job): i for i, job in enumerate(jobs)}
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            for ref in done:
                i = pending.pop(ref)
                try:
                    result = ray.get(ref)
                except RayTaskError as error:  # fn raised: no retry
                    cause = error.cause if isinstance(error.cause, BaseException) else error
                    result = JobFailed(f"{type(cause).__name__}: {cause}", 0)
                except RayError as error:  # the worker or its node died, after Ray's retries
                    result = JobFailed(f"{type(error).__name__} after {retries} retries: "
                                       f"{str(error).splitlines()[0] if str(error) else ''}", retries + 1)
                yield i, result
    finally:
        if started_here:
            ray.shutdown()
