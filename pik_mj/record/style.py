"""How the overlays of a recording look: colours (RGB), sizes [m], lift [m].

Overlays that lie on the ground (support polygon, SCFR, ZMP, the CoM's
projection, footsteps) are drawn above it, in bright colours, so that the floor
and the soles do not hide them (:attr:`pik_mj.record.geometry.Measures.lift`).
"""

from __future__ import annotations

#: Least height [m] above the ground at which ground overlays are drawn (a
#: recording of a standing robot draws them above its soles).
LIFT = 0.012

#: Radius [m] of polygon outlines.
OUTLINE_RADIUS = 0.008

COM = (255, 40, 40)
COM_RADIUS = 0.035
COM_TARGET = (60, 255, 140)
COM_TARGET_RADIUS = 0.028
#: The CoM's ground projection and the line down to it.
COM_GROUND = (255, 110, 110)
COM_GROUND_RADIUS = 0.02

SUPPORT_POLYGON = (0, 225, 255)
MARGIN = (255, 170, 0)
SCFR = (120, 255, 60)
FOOTSTEP = (170, 170, 255)

ZMP = (255, 0, 255)
ZMP_REFERENCE = (255, 235, 0)
ZMP_INVERSE_DYNAMICS = (255, 130, 0)
#: The ZMP from the feet's force sensors (what the robot measures).
ZMP_FORCE_SENSORS = (0, 200, 255)
ZMP_RADIUS = 0.035

TARGET = (60, 255, 140)
TARGET_RADIUS = 0.03
#: Axis length [m] of task frames (target and current).
FRAME_AXIS = 0.15

CONTACT = (255, 0, 255)
CONTACT_RADIUS = 0.012
FEASIBLE = (89, 161, 79)  # the static check's equilibrium flag (1 = yes)
#: Length of the arrow of a force equal to the robot's weight, as a fraction of
#: the robot's height: contact forces are drawn at ``FORCE_PER_WEIGHT * h / (m g)``
#: [m/N].
FORCE_PER_WEIGHT = 0.6
#: Contact force scale [m/N] when the robot's weight is unknown.
DEFAULT_FORCE_SCALE = 1e-3

#: The reference pose of a motion, drawn as a second robot: translucent, with
#: its primitives' major wireframe (RGBA).
REFERENCE = (80, 160, 255, 90)

#: Colours of the task-error series of one level's plot, in the order the
#: tasks first appear in it (Tableau 10: apart from each other on the viewer's
#: dark background); more tasks than colours start again at the first.
SERIES = (
    (78, 121, 167),
    (242, 142, 43),
    (225, 87, 89),
    (118, 183, 178),
    (89, 161, 79),
    (237, 201, 72),
    (176, 122, 161),
    (255, 157, 167),
    (156, 117, 95),
    (186, 176, 172),
)
