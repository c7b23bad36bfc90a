"""Printable solids: one watertight body per material (``docs/geometry-and-export.md``).

A design becomes *pieces* (2D work in shapely, solids in manifold3d, trimesh never):

* **panels**: the rigid part of each panel (its outline less the hinge strips of every
  hinge, w/2 on each side of a fold line, less the notches of triangular interfaces),
  extruded symmetrically about z = 0 to the panel thickness and placed with its pose;
* **hinge strips**: the flat strip (width w = R |rho|, length of the fold line, hinge
  thickness; stepped profile, cut by slots) built as a prism subdivided across its
  width (one slice per <= 5 deg of bend and at every step), then bent with the arc
  model: the strip line at width u maps like the arc end of ``kinematics`` with w
  replaced by u and angle rho u / w, then the parent's pose;
* **teeth** (triangular interface): a 2D region in each neighbouring panel, added to
  the hinge and subtracted from the panel before extrusion, so the two share surfaces.

Pieces of one material are united per material (touching bodies of two materials are
never merged); bodies of different materials may touch but must not overlap, which
:func:`build_assembly` checks. States: ``permanent`` (printed: hinges bent to their
target angle) and ``programmed`` (flat sheet).
"""

from .assembly import HingeAxes, build_assembly, build_pieces, hinge_axes, panel_solids
from .bed import bed_report
from .hinges import arc_transform, hinge_segments, state_angles, strip_profile
from .layout import layout
from .solids import (BED_TOL, BEND_VOLUME_RATIO_MIN, BOTTOM_FACE_RAD, CLEAN_EPS, MAX_SLICE_RAD, MIN_AREA,
                     STATES, TEETH_GAP, TEETH_OVERLAP, TOOTH_END_MARGIN, TOOTH_LAND_FRACTION, VOLUME_RTOL,
                     Assembly, Body, Piece, apply_pose)

__all__ = ["Assembly", "HingeAxes", "hinge_axes", "BED_TOL", "BEND_VOLUME_RATIO_MIN", "BOTTOM_FACE_RAD", "Body", "CLEAN_EPS",
           "MAX_SLICE_RAD", "MIN_AREA", "Piece", "STATES", "TEETH_GAP", "TEETH_OVERLAP", "TOOTH_END_MARGIN",
           "TOOTH_LAND_FRACTION", "VOLUME_RTOL", "apply_pose", "arc_transform", "bed_report", "build_assembly",
           "build_pieces", "hinge_segments", "layout", "panel_solids", "state_angles", "strip_profile"]
