"""debug.cl's kernels at chosen points (no Blender needed)."""
import numpy as np

from ppm_engine.render.device import SHADING_GROUP


def emitter_picks(r, pts, nrm, n_u):
    """Next-event estimation's pick at points pts (normals nrm, float4 rows) from n_u
    stratified numbers (kernels/test/debug.cl emitter_pick_at), on renderer r's scene: per point and
    emitter, "counts" how often it was picked, "pmf" the probability the pick returned (-1:
    never picked) and "table" the one the MIS of a ray that finds it uses."""
    import pyopencl as cl
    dev, n = r.device, len(pts)
    m = int(r.scene.emitters.info["n_emitters"][0])
    bufs = {k: cl.Buffer(dev.context, cl.mem_flags.READ_WRITE, 4 * n * m)
            for k in ("counts", "pmf", "table")}
    k = dev.programs.get("test/debug.cl").launch("emitter_pick_at", "test")
    k(dev.queue, n, SHADING_GROUP, **r.scene.args, points=dev.upload(pts, "p"),
      nrm=dev.upload(nrm, "n"), n_u=np.uint32(n_u), **bufs, n=np.uint32(n))
    got = {}
    for key, dt in (("counts", np.uint32), ("pmf", np.float32), ("table", np.float32)):
        got[key] = np.empty((n, m), dt)
        cl.enqueue_copy(dev.queue, got[key], bufs[key])
    return got
