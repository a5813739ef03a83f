"""One frame's passes as tasks on a Dask cluster (``distributed``'s scheduler and workers): each
task renders a range of passes with the global radius schedule on its worker's device and
returns its Part; the parts are merged as they arrive (ppm_engine/render/parts.py).

- ``tcp://HOST:PORT``: an existing scheduler (``dask scheduler`` on one machine, ``dask worker
  tcp://HOST:PORT --nthreads 1`` on each render node, this package installed there).
- ``local:N``: a LocalCluster of N worker processes on this machine, on the loopback interface
  only, closed at the end (the tests' way).

A worker lost mid-task (its process killed, its machine gone) loses its task: the scheduler
runs it again on another worker (Dask's own resilience), and a task that raised is retried
(``RETRIES``).  The merge refuses a pass counted twice and the render checks that every pass
came back, so each pass is counted once.  Each worker keeps one Renderer per scene and settings
between its tasks (kernels, BVH and buffers built once; ``reset`` gives each task a new film).

``distributed`` is an optional dependency (``pip install "ppm-engine[dask]"``): the add-on never
imports this module, and the CLI says how to install it where it is missing.
"""
from __future__ import annotations

import math
import threading

from ppm_engine.errors import UsageError
from ppm_engine.render.parts import Part, check_splittable, merge, scene_digest

# tasks per worker when the passes per task are not given: a few, so that a lost task costs
# little and faster workers take more
TASKS_PER_WORKER = 4
RETRIES = 2


def _distributed():
    try:
        import distributed
    except ImportError:
        raise UsageError("--dask needs Dask's 'distributed' package: pip install distributed "
                         "(or pip install \"ppm-engine[dask]\")") from None
    return distributed


# -- on a worker --------------------------------------------------------------------------------
_worker_renderers: dict = {}
_worker_lock = threading.Lock()


def render_task(scene, options, first: int, stop: int) -> Part:
    """Passes ``first`` .. ``stop - 1`` (indices from 0) of ``scene``: a task on a worker.  The
    worker's Renderer for this scene and these options is kept for its next task."""
    from ppm_engine.render.parts import render_range
    from ppm_engine.render.renderer import Renderer
    key = (scene_digest(scene), repr(options))
    with _worker_lock:
        r = _worker_renderers.get(key)
        if r is None:
            for old in _worker_renderers.values():
                old.close()
            _worker_renderers.clear()
            r = _worker_renderers[key] = Renderer(scene, options)
        else:
            r.reset(options)
        return render_range(scene, options, range(first, stop), renderer=r)


# -- on the client ------------------------------------------------------------------------------
def tasks(passes: list[int], n_tasks: int) -> list[tuple[int, int]]:
    """Consecutive pass indices split into about ``n_tasks`` ranges [first, stop)."""
    lo, hi = passes[0], passes[-1] + 1
    if passes != list(range(lo, hi)):
        raise ValueError("a Dask render splits one run of consecutive passes")
    size = max(1, math.ceil((hi - lo) / max(n_tasks, 1)))
    return [(a, min(a + size, hi)) for a in range(lo, hi, size)]


def render_on_dask(client, scene, options, passes, task_passes: int | None = None,
                   progress=None, on_part=None) -> Part:
    """``passes`` of ``scene`` rendered as tasks on ``client``'s cluster and merged as they
    arrive; ``progress(done, total, None)`` per part; ``on_part(part)`` too (the tests kill a
    worker there).  Raises PartError where passes are missing or counted twice."""
    distributed = _distributed()
    check_splittable(options)
    passes = list(passes)
    workers = max(len(client.scheduler_info()["workers"]), 1)
    n = (math.ceil(len(passes) / task_passes) if task_passes
         else TASKS_PER_WORKER * workers)
    ranges = tasks(passes, n)
    [scene_f] = client.scatter([scene], broadcast=True, hash=False)
    futures = [client.submit(render_task, scene_f, options, a, b, retries=RETRIES, pure=False)
               for a, b in ranges]
    merged, done = None, 0
    for future in distributed.as_completed(futures):
        part = future.result()
        merged = part if merged is None else merge([merged, part])
        done += len(part.passes)
        if on_part is not None:
            on_part(part)
        if progress is not None:
            progress(done, len(passes), None)
    if merged is None or merged.passes.tolist() != passes:
        from ppm_engine.render.parts import PartError
        raise PartError("the cluster's parts do not hold every pass once")
    return merged


def dask_runner(address: str, task_passes: int | None = None, log=None,
                device: str | None = None):
    """A ``run(scene, options, passes, progress)`` for batch.render_split: the passes on the
    Dask cluster at ``address`` (tcp://HOST:PORT, or local:N for a LocalCluster of N workers on
    the loopback interface), each worker on ``device`` (a name or key as RenderOptions.device),
    by default its own default device (a GPU if it has one): the scene file's device is this
    machine's."""
    distributed = _distributed()
    if device is not None and "," in device:
        raise UsageError("with --dask each worker renders on one device: start a worker per "
                         "device (dask worker ... --nthreads 1) and give one --device or none")
    if task_passes is not None and task_passes < 1:
        raise UsageError("--task-passes must be at least 1")
    if address.startswith("local:"):
        try:
            n = int(address[len("local:"):])
        except ValueError:
            n = 0
        if n < 1:
            raise UsageError(f"--dask {address}: local:N needs a number of workers, such as "
                             "local:2")
    elif not address.startswith(("tcp://", "tls://", "ws://", "wss://")):
        raise UsageError(f"--dask {address}: give the scheduler as tcp://HOST:PORT, or local:N")

    def run(scene, options, passes, progress):
        options = options.replace(device=device or "", devices=())
        if address.startswith("local:"):
            cluster = distributed.LocalCluster(n_workers=n, threads_per_worker=1,
                                               processes=True, host="127.0.0.1",
                                               dashboard_address=None)
        else:
            cluster = None
        try:
            with distributed.Client(cluster if cluster is not None else address,
                                    timeout="30s") as client:
                if log is not None:
                    log(f"Dask: {len(client.scheduler_info()['workers'])} workers at "
                        f"{client.scheduler.address}")
                return render_on_dask(client, scene, options, passes, task_passes, progress)
        except OSError as e:
            from ppm_engine.errors import PPMError
            raise PPMError(f"cannot reach the Dask scheduler at {address}: {e}") from None
        finally:
            if cluster is not None:
                cluster.close()
    return run
