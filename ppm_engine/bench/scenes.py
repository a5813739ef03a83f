"""The benchmark's data about its scenes (ppm_engine.scenes builds them): per scene, the floor
region counted as "caustic pixels" (curves.caustic_mask: a world-space disk on the floor, or
the set of floor points that see the light's mirror image through the mirror rectangle, exact;
pixels whose camera ray meets one of the listed spheres first are left out), and the objects
Cycles' shadow caustics (MNEE) needs flagged."""
from __future__ import annotations

from ..scenes.bulb_box import BALL_CENTER, BULB_CENTER
from ..scenes.caustics import BALL, LIGHT_RADIUS, POINT_POS, mirror_corners, mirror_image

# scene name -> caustic mask description (used by curves.caustic_mask)
CAUSTIC_MASKS = {
    # the Cornell box has no caustic: the whole floor counts (its indirect light)
    "cornell_box": {"kind": "disk", "center": (0.0, 0.0, 0.0), "radius": 1.5,
                    "occluders": [], "note": "the floor (no caustic in this scene)"},
    # the furnace: no caustic, no floor; every pixel counts
    "furnace": {"kind": "all", "occluders": [], "note": "every pixel (no caustic)"},
    # the floor beside and under the glass ball, where its caustic falls
    "bulb_box": {"kind": "disk", "center": (BALL_CENTER[0] + 0.07, BALL_CENTER[1] + 0.05, 0.0),
                 "radius": 0.45, "occluders": [(BALL_CENTER, 0.3), (BULB_CENTER, 0.15)],
                 "note": "floor within 0.45 m of the point below the bulb-to-ball line, "
                         "not hidden by the ball"},
    "glass_caustic": {"kind": "disk", "center": (0.43, 0.0, 0.0), "radius": 0.35,
                      "occluders": [BALL],
                      "note": "floor within 0.35 m of where the ray from the spot through the "
                              "ball centre meets the floor, not hidden by the ball"},
    "mirror_caustic": {"kind": "mirror", "light": POINT_POS, "light_radius": LIGHT_RADIUS,
                       "corners": None, "occluders": [],
                       "note": "floor points that see the light's mirror image through the "
                               "mirror (the reflected patch, exact)"},
}

CAUSTIC_MASKS["mirror_caustic"]["corners"] = mirror_corners().tolist()
CAUSTIC_MASKS["mirror_caustic"]["light_image"] = mirror_image(POINT_POS).tolist()

# objects Cycles' shadow caustics (MNEE) uses, per scene: (casters, receivers, lights)
MNEE_OBJECTS = {
    "glass_caustic": (["GlassBall"], ["Floor", "Back"], ["Spot"]),
    "mirror_caustic": (["Mirror"], ["Floor", "Back"], ["Point"]),
}
