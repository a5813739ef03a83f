"""The passes of one SPPM iteration, each a small object owning its kernels (arguments bound by
name, device/program.py Launch) and its timing label.  Renderer.iterate() runs them in the
paper's order (Hachisuka & Jensen 2010):

    EyePass            "eye"     camera rays through specular bounces to visible points; direct
                                 light by next-event estimation
    HashBuild.grid     "grid"    the grid over this pass's visible points (before the photons,
                                 so that photons outside it are not stored: departs from the
                                 paper, which builds it after)
    PhotonPass         "photon"  photons from the emitters, stored at diffuse hits
    HashBuild.build    "hash"    the stochastic spatial hash: one photon and a count per entry
    Gather             "gather"  each visible point reads the cells its disc overlaps
    ProgressiveUpdate  "update"  N, R and the photon sum per pixel; the pass's sample into the
                                 film ("adaptive": which pixels go on)
"""
from ppm_engine.render.passes.eye import EyePass, VisiblePoints
from ppm_engine.render.passes.gather import Gather, unshaded
from ppm_engine.render.passes.hash_build import HashBuild
from ppm_engine.render.passes.photons import PhotonPass
from ppm_engine.render.passes.update import ProgressiveUpdate

__all__ = [
           "EyePass",
           "Gather",
           "HashBuild",
           "PhotonPass",
           "ProgressiveUpdate",
           "VisiblePoints",
           "unshaded",
]
