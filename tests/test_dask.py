"""A frame's passes as tasks on a Dask cluster (ppm_engine/render/cluster.py), on a LocalCluster
of two worker processes on the loopback interface: the image of one process's run, also when a
worker is killed mid-run (its tasks run again elsewhere; every pass counted once)."""
import os
import signal

import numpy as np
import pytest

from ppm_engine.oracle.procedural import cornell_box
from ppm_engine.render.options import RenderOptions
from ppm_engine.render.parts import render_range

distributed = pytest.importorskip("distributed")

W = 24
PASSES = 8


@pytest.fixture(scope="module")
def client():
    # connections to the worker killed below give up after this (Dask's default is 30 s: the
    # killed-worker test once took 30 s on a cold kernel cache, likely a gather from the dead
    # worker waiting that long before its task was run again)
    import dask
    with dask.config.set({"distributed.comm.timeouts.connect": "5s"}), \
            distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                     host="127.0.0.1", dashboard_address=None) as cluster, \
            distributed.Client(cluster) as c:
        yield c


@pytest.fixture(scope="module")
def scene_and_one_run(pocl_key):
    scene = cornell_box(W, W)
    options = RenderOptions(specialize=False, radius_schedule="global",
                            photons_per_pass=4096, indirect="photons")
    return scene, options, render_range(scene, options, range(PASSES))


def test_two_workers_give_one_process_image(client, scene_and_one_run):
    from ppm_engine.render.cluster import render_on_dask
    scene, options, one = scene_and_one_run
    done = []
    part = render_on_dask(client, scene, options, range(PASSES), task_passes=2,
                          progress=lambda k, n, _: done.append((k, n)))
    assert part.passes.tolist() == list(range(PASSES))
    assert done[-1] == (PASSES, PASSES) and len(done) == 4
    np.testing.assert_allclose(part.image(), one.image(), rtol=1e-6, atol=1e-6)


def test_a_killed_worker_still_counts_every_pass_once(client, scene_and_one_run):
    """The first part back kills a worker's process (SIGKILL): the scheduler runs its tasks
    again on the other worker (and on the nanny's new one); the merge holds every pass once
    and is the one-process image."""
    from ppm_engine.render.cluster import render_on_dask
    scene, options, one = scene_and_one_run
    killed = []

    def kill_one(part):
        if not killed:
            worker = next(iter(client.scheduler_info()["workers"]))
            pid = client.run(os.getpid, workers=[worker])[worker]
            os.kill(pid, signal.SIGKILL)
            killed.append(worker)
    part = render_on_dask(client, scene, options, range(PASSES), task_passes=1,
                          on_part=kill_one)
    assert killed
    assert part.passes.tolist() == list(range(PASSES))
    np.testing.assert_allclose(part.image(), one.image(), rtol=1e-6, atol=1e-6)


def test_cli_dask_errors_are_one_line(cli, tmp_path):
    blend = tmp_path / "none.blend"
    proc = cli("render", blend, "-o", tmp_path / "x.exr", "--dask", "local:two")
    assert proc.returncode == 2 and "local:N needs a number" in proc.stderr
    assert "Traceback" not in proc.stderr
    proc = cli("render", blend, "-o", tmp_path / "x.exr", "--dask", "scheduler:8786")
    assert proc.returncode == 2 and "tcp://HOST:PORT" in proc.stderr


def test_without_distributed_the_message_says_how_to_install(monkeypatch):
    from ppm_engine.errors import UsageError
    from ppm_engine.render.cluster import dask_runner
    monkeypatch.setitem(__import__("sys").modules, "distributed", None)
    with pytest.raises(UsageError, match="pip install distributed"):
        dask_runner("local:2")
