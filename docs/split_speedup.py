"""Wall time of one frame's passes on one device, on two devices (MultiRenderer; PoCL's CPU twice
stands for two where there is one device) and on a Dask LocalCluster of two workers
(docs/BENCHMARKS.md, "Passes rendered apart"):

    python docs/split_speedup.py [SCENE] [PASSES] [SIZE]     (default cornell_box 64 128)

SCENE is an example scene (python -m ppm_engine example NAME), rendered with the global radius
schedule at SIZE x SIZE; every way renders the same passes, and each image is checked against
the first (the same device: to float rounding).  Kernels are built (and cached) before the
timings; the Dask time includes starting the cluster."""
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def main(name="cornell_box", passes=64, size=128):
    import bpy

    from ppm_engine.blender.export import export_scene
    from ppm_engine.blender.harness import ensure_registered
    from ppm_engine.blender.properties import to_options
    from ppm_engine.blender.scenes import save_example
    from ppm_engine.render.device import list_devices
    from ppm_engine.render.multi_device import render_devices
    from ppm_engine.render.parts import render_range
    ensure_registered()
    path = Path(tempfile.gettempdir()) / f"ppm_speedup_{name}.blend"
    save_example(name, str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    arrays = export_scene(bpy.context.evaluated_depsgraph_get())
    devices = [d.key for d in list_devices()]
    options = to_options(scene.ppm).replace(radius_schedule="global", passes=passes,
                                            device=devices[0])
    render_range(arrays, options, range(2))          # kernels built and cached
    two = devices[:2] if len(devices) > 1 else [devices[0], devices[0] + "#1"]
    rows = []
    t0 = time.perf_counter()
    first = render_range(arrays, options, range(passes))
    rows.append(("one device", time.perf_counter() - t0, first))
    t0 = time.perf_counter()
    rows.append((f"two devices ({', '.join(two)})", None,
                 render_devices(arrays, options, range(passes), two)))
    rows[-1] = (rows[-1][0], time.perf_counter() - t0, rows[-1][2])
    try:
        import distributed

        from ppm_engine.render.cluster import render_on_dask
        t0 = time.perf_counter()
        with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                      host="127.0.0.1", dashboard_address=None) as cluster, \
                distributed.Client(cluster) as client:
            part = render_on_dask(client, arrays, options, range(passes))
        rows.append(("Dask local:2", time.perf_counter() - t0, part))
    except ImportError:
        print("(no 'distributed': the Dask row is left out)")
    base = rows[0][1]
    for label, seconds, part in rows:
        diff = float(np.abs(part.image() - first.image()).max())
        print(f"{name} {size}x{size}, {passes} passes, {label}: {seconds:.1f} s "
              f"(speed-up {base / seconds:.2f}x), max difference from one device {diff:.1e}")


if __name__ == "__main__":
    args = sys.argv[1:]
    main(args[0] if args else "cornell_box", int(args[1]) if len(args) > 1 else 64,
         int(args[2]) if len(args) > 2 else 128)
