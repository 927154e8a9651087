"""Sweeps on a Dask `distributed` cluster: the runner's cluster backend (`drtlab experiment
--scheduler ADDRESS` or `--workers N`).

Each render is one task: every batch of study repetitions, and every ground-truth batch. A task ships what the
render needs and nothing more: the parsed scene description (a few KB, so a scene given by path on
the client needs no copy on the workers), the sampler, integrator, resolution, spp, seed and thread
count, and the backend object (the renderer entry point, pickled by reference to the installed
drtlab). What comes back is the image (float64, as rendered), its timings and the worker's address.
The CLIENT turns that into the run record (metrics against the ground truth, which never leaves the
client) and writes it through `run_store`, so every result file is written once, atomically, by one
process, and resuming works exactly as for an in-process sweep. Renders are deterministic per seed,
so the results are bit-identical to a local run whatever worker or thread count renders them.

Dask is imported only when a cluster is asked for: the in-process path does not need it.
"""
from __future__ import annotations

import math
import os
import re
import time
import uuid
from contextlib import contextmanager
from dataclasses import replace
from typing import Iterator

from drtlab.errors import InputError

CONNECT_TIMEOUT = 5.0          # seconds: an unreachable scheduler fails fast, before any long work
_ADDRESS = re.compile(r"^(?:tcp://)?(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):(?P<port>\d{1,5})$")
# Passed through to LocalCluster workers: without the kernel cache every worker recompiles
# every kernel variant (seconds each).
WORKER_ENV = ("WARP_CACHE_PATH",)


def scheduler_address(text: str, field: str = "--scheduler") -> str:
    """`tcp://host:port` or `host:port` -> `tcp://host:port` (the form Dask connects to)."""
    m = _ADDRESS.match(text.strip()) if isinstance(text, str) else None
    if m is None or not 1 <= int(m["port"]) <= 65535:
        raise InputError(field, f"must look like tcp://HOST:PORT or HOST:PORT (e.g. "
                                f"tcp://10.0.0.5:8786), got {text!r}")
    return f"tcp://{m['host']}:{int(m['port'])}"


# ---------------------------------------------------------------------------------------------------
# What runs on a worker (module level: pickled by reference, so workers import the installed drtlab)
# ---------------------------------------------------------------------------------------------------

def render_task(backend, scene, spp: int, sampler: str, integrator: str, seed: int, res, threads: int,
                plugins: tuple = ()):
    """One render on a worker -> (RenderResult with a plain array, wall seconds, worker address)."""
    import numpy as np
    from drtlab.experiments.study.backend import RenderResult
    from drtlab.estimators.plugins import ensure_shipped
    ensure_shipped(plugins)
    t0 = time.perf_counter()
    r = backend.render(scene, spp=spp, sampler=sampler, integrator=integrator, seed=seed, res=res,
                       threads=threads)
    wall = time.perf_counter() - t0
    # Only what the client reads travels back (RenderStats also holds the scene and variant info).
    out = RenderResult(image=np.asarray(r.image), render_seconds=float(r.render_seconds),
                       compile_seconds=float(getattr(r, "compile_seconds", 0.0)),
                       samples_per_second=float(getattr(r, "samples_per_second", 0.0)))
    return out, wall, _worker_address()


def render_batch_task(backend, scene, spp: int, sampler: str, integrator: str, seeds: list, res,
                      threads: int, plugins: tuple = ()):
    """One batch of repetitions on a worker -> (BatchResult with a plain array, wall seconds, worker
    address). `plugins` (drtlab.estimators.plugins.shipped()) are loaded first, once per worker process."""
    import numpy as np
    from drtlab.experiments.study.backend import BatchResult
    from drtlab.estimators.plugins import ensure_shipped
    ensure_shipped(plugins)
    t0 = time.perf_counter()
    r = backend.batch(scene, spp=spp, sampler=sampler, integrator=integrator, seeds=seeds, res=res,
                      threads=threads)
    wall = time.perf_counter() - t0
    out = BatchResult(images=np.asarray(r.images), render_seconds=float(r.render_seconds),
                      cpu_seconds=float(r.cpu_seconds), compile_seconds=float(r.compile_seconds))
    return out, wall, _worker_address()


def _worker_address() -> str:
    try:
        from distributed import get_worker
        return get_worker().address
    except (ImportError, ValueError):          # not inside a worker (called directly)
        return "local"


def _worker_code_version() -> str:
    from drtlab.kernels import CODE_VERSION
    return CODE_VERSION


# ---------------------------------------------------------------------------------------------------
# The client side
# ---------------------------------------------------------------------------------------------------

class DaskExecutor:
    """A Dask client (and the LocalCluster it owns, if any) the runner renders through."""

    def __init__(self, client, cluster=None):
        self.client = client
        self.cluster = cluster
        self.submitted = 0                     # tasks sent: tests check that a resume sends few
        self._token = uuid.uuid4().hex[:8]     # keeps task keys of two sweeps apart on one scheduler

    @classmethod
    def connect(cls, address: str, timeout: float | None = None, backend=None) -> "DaskExecutor":
        """A running scheduler: reachable within `timeout`, with at least one worker, whose workers
        run the same kernel code as `backend` (else their images would silently differ)."""
        import dask
        from distributed import Client
        timeout = CONNECT_TIMEOUT if timeout is None else timeout
        with dask.config.set({"distributed.comm.timeouts.connect": f"{timeout}s"}):
            try:
                client = Client(address, timeout=f"{timeout}s", set_as_default=False)
            except (OSError, TimeoutError) as e:
                raise InputError("--scheduler", f"cannot reach a Dask scheduler at {address} within "
                                                f"{timeout:g} s ({_reason(e)})") from None
        ex = cls(client)
        try:
            ex._check_workers(address, timeout, backend)
        except BaseException:
            ex.close()
            raise
        return ex

    def _check_workers(self, address: str, timeout: float, backend) -> None:
        try:
            self.client.wait_for_workers(1, timeout=timeout)
        except TimeoutError:
            raise InputError("--scheduler", f"the scheduler at {address} has no workers; start some "
                                            f"with `dask worker {address}`") from None
        if backend is None or not backend.name.startswith("warp"):
            return
        try:
            versions = self.client.run(_worker_code_version)
        except Exception as e:                 # noqa: BLE001 - e.g. drtlab not installed there
            raise InputError("--scheduler", f"the workers of {address} cannot run drtlab "
                                            f"({_reason(e)}); install drtlab on every worker") from None
        odd = sorted(w for w, v in versions.items() if v != backend.code_version)
        if odd:
            raise InputError("--scheduler", f"worker {odd[0]} runs other kernel code "
                                            f"({versions[odd[0]]}, here {backend.code_version}); "
                                            f"install the same drtlab on every worker")

    @classmethod
    def local(cls, n_workers: int) -> "DaskExecutor":
        """A LocalCluster of `n_workers` single-threaded worker processes on this machine."""
        from distributed import Client, LocalCluster
        env = {k: os.environ[k] for k in WORKER_ENV if k in os.environ}
        # dashboard on a free port: the scheduler's HTTP server would otherwise take 8787 or warn
        cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                               dashboard_address=":0", env=env)
        try:
            client = Client(cluster, set_as_default=False)
        except BaseException:
            cluster.close()
            raise
        return cls(client, cluster)

    def close(self) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def workers(self) -> list[str]:
        return sorted(self.client.scheduler_info()["workers"])

    def _submit(self, name: str, backend, scene, spp, sampler, integrator, seed, res, threads):
        self.submitted += 1
        # A fresh key per submission: resubmitting the key of a just-cancelled task (a resume in the
        # same session) could otherwise pick up the cancelled one.
        from drtlab.estimators.plugins import shipped
        return self.client.submit(render_task, backend, scene, spp, sampler, integrator, seed,
                                  tuple(res), threads or 1, shipped(),
                                  key=f"drtlab-{name}-{self._token}-{self.submitted}")

    def render_batches(self, backend, scene, batches: list, threads: int | None) -> Iterator[tuple]:
        """Submit every batch (runner._Batch) at once; yield (batch, result, wall, worker) as each
        finishes, so the caller commits it at once (a killed client loses only the batches still in
        flight)."""
        from distributed import as_completed

        from drtlab.estimators.plugins import shipped
        plugins = shipped()
        futures = {}
        for b in batches:
            r = b.runs[0]
            self.submitted += 1
            f = self.client.submit(render_batch_task, backend, scene, r.spp, r.sampler, r.integrator,
                                   [x.seed for x in b.runs], tuple(r.resolution), threads or 1, plugins,
                                   key=f"drtlab-batch-{b.cell}-{b.batch_id}-{self._token}-{self.submitted}")
            futures[f.key] = (f, b)
        try:
            for f in as_completed([f for f, _ in futures.values()], loop=self.client.loop):
                result, wall, worker = f.result()
                yield futures.pop(f.key)[1], result, wall, worker
        finally:
            if futures:                        # stopped early: do not leave work on the cluster
                self.client.cancel([f for f, _ in futures.values()])

    def ground_truth_backend(self, backend, scene_ref, gt_spp: int):
        """`backend` whose render() of a ground-truth batch returns the result of a task.

        `ground_truth.ensure_ground_truth` renders its batches one after another and accumulates
        them in batch order (the float64 Welford sums depend on the order). At its first batch this
        wrapper submits that batch and every later one at once; each call then waits for its own
        batch only, so the batches render in parallel and are still added in the same order."""
        from drtlab.experiments.seeds import gt_seed
        futures: dict = {}

        def render(scene, *, spp, sampler, integrator, seed, res, threads=None):
            if seed not in futures:
                need = max(math.ceil(gt_spp / spp), 2)      # as ensure_ground_truth counts them
                seeds = [gt_seed(scene_ref.key, integrator, res, b) for b in range(need)]
                todo = seeds[seeds.index(seed):] if seed in seeds else [seed]
                for s in todo:
                    if s not in futures:
                        futures[s] = self._submit(f"gt-{scene_ref.key}-{s:08x}", backend, scene, spp,
                                                  sampler, integrator, s, res, threads)
            result, _, _ = futures.pop(seed).result()
            return result

        return replace(backend, render=render)


def _reason(e: BaseException) -> str:
    text = " ".join(str(e).split()) or type(e).__name__
    return text if len(text) <= 160 else text[:157] + "..."


@contextmanager
def open_executor(scheduler: str | None, workers: int | None, backend=None):
    """The executor the CLI flags ask for (closed on exit), or None: the in-process sweep."""
    if scheduler is not None and workers is not None:
        raise InputError("--workers", "give either --scheduler or --workers, not both")
    if scheduler is None and workers is None:
        yield None
        return
    if scheduler is not None:
        ex = DaskExecutor.connect(scheduler_address(scheduler), backend=backend)
    else:
        ex = DaskExecutor.local(workers)
    with ex:
        yield ex
