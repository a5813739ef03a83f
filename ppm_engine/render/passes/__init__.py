"""The passes of one SPPM iteration, each a small object owning its kernels (arguments bound by
name, device/program.py Launch) and its timing label.  Every pass has one shape
(passes/context.py): built as ``Pass(ctx)`` on a PassContext (the device and the render's
buffers; keyword-only settings where a pass has them), run as ``enqueue(q, it)`` with an
Iteration (this pass's index and options, its photon count ...), which returns the launches as
(label, event) pairs, or None where ``it.interrupt`` stopped it.  Renderer.iterate() runs them
in the paper's order (Hachisuka & Jensen 2010):

    EyePass        "eye"       camera rays through specular bounces to visible points; direct
                               light by next-event estimation
    PathFilter     "filter"    (run by EyePass, eye paths only) each path's light past its second
                               vertex averaged over its cell's (passes/path_filter.py)
    GridSetup      "grid"      the grid over this pass's visible points (before the photons,
                               so that photons outside it are not stored: departs from the
                               paper, which builds it after)
    PhotonPass     "photon"    photons from the emitters, stored at diffuse hits
    HashBuild      "hash"      the stochastic spatial hash: one photon and a count per entry
    Gather         "gather"    each visible point reads the cells its disc overlaps
    VolumeGather   "volume"    the volume photons' hash, gathered along the camera's segments
                               in media (passes/volume.py; scenes with a scattering medium)
    RadiusUpdate   "update"    N, R and the photon sum per pixel
    AddSample      "update"    the pass's sample into the film
    Converge       "adaptive"  which pixels go on (adaptive sampling; Converge.due says when)
"""
from ppm_engine.render.passes.context import Iteration, PassContext
from ppm_engine.render.passes.eye import EyePass, VisiblePoints
from ppm_engine.render.passes.gather import Gather, unshaded
from ppm_engine.render.passes.hash_build import GridSetup, HashBuild
from ppm_engine.render.passes.photons import PhotonPass
from ppm_engine.render.passes.update import AddSample, Converge, ProgressiveUpdate, RadiusUpdate

__all__ = [
           "AddSample",
           "Converge",
           "EyePass",
           "Gather",
           "GridSetup",
           "HashBuild",
           "Iteration",
           "PassContext",
           "PhotonPass",
           "ProgressiveUpdate",
           "RadiusUpdate",
           "VisiblePoints",
           "unshaded",
]
