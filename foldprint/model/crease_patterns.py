"""Classic rigid-origami crease patterns as FOLD dictionaries (mm, creasePattern frame):
a Miura-ori patch, a single degree-4 vertex and a waterbomb base. Used by the shipped
templates, the tests and ``docs/loops.md``; read them with
:func:`foldprint.io.fold_format.design_from_fold`.

Fold angles follow FOLD: + valley, - mountain (deg).
"""

from __future__ import annotations

import math


def _fold(vertices, faces, edges, assignment, angles, title: str, materials=None) -> dict:
    out = {"file_spec": 1.2, "file_creator": "foldprint.model.crease_patterns", "file_classes": ["singleModel"],
           "frame_classes": ["creasePattern"], "frame_attributes": ["2D"], "frame_unit": "mm",
           "frame_title": title, "vertices_coords": [[float(x), float(y)] for x, y in vertices],
           "faces_vertices": faces, "edges_vertices": edges, "edges_assignment": assignment,
           "edges_foldAngle": [float(a) for a in angles]}
    if materials is not None:
        out["edges_foldprint:material"] = materials
    return out


def degree4_ratio(alpha_deg: float, beta_deg: float) -> float:
    """Flat-foldable degree-4 vertex with consecutive sector angles alpha, beta,
    180 - alpha, 180 - beta (deg) between creases 1-2, 2-3, 3-4, 4-1: along its folding
    motion rho3 = -rho1, rho4 = rho2 and

        tan(rho2 / 2) = sin((alpha + beta) / 2) / sin((beta - alpha) / 2) * tan(rho1 / 2)

    (the one-degree-of-freedom relation; Huffman 1976, Tachi 2009, Evans et al. 2015).
    This returns the magnitude; on the branch :func:`degree4` builds (crease 1 and 2 of
    opposite sign) ``tan(rho2 / 2) = -ratio * tan(rho1 / 2)``."""
    a, b = math.radians(alpha_deg), math.radians(beta_deg)
    return math.sin((a + b) / 2) / math.sin((b - a) / 2)


def degree4(alpha_deg: float = 60.0, beta_deg: float = 80.0, radius: float = 30.0,
            rho1_deg: float = -90.0, material: str | None = None) -> dict:
    """One flat-foldable degree-4 vertex at the origin: four triangular panels, creases
    1..4 at directions 0, alpha, alpha + beta, 180 + beta (deg), target angles on the
    folding branch through ``rho1_deg`` (crease 1 mountain, 2-4 valleys for rho1 < 0)."""
    dirs = [0.0, alpha_deg, alpha_deg + beta_deg, 180.0 + beta_deg]
    verts = [(0.0, 0.0)] + [(radius * math.cos(math.radians(t)), radius * math.sin(math.radians(t)))
                            for t in dirs]
    faces = [[0, 1 + i, 1 + (i + 1) % 4] for i in range(4)]
    edges = [[0, 1 + i] for i in range(4)] + [[1 + i, 1 + (i + 1) % 4] for i in range(4)]
    t1 = math.tan(math.radians(rho1_deg) / 2)
    rho2 = abs(math.degrees(2 * math.atan(degree4_ratio(alpha_deg, beta_deg) * t1)))
    sgn = -1.0 if rho1_deg < 0 else 1.0
    rho = [rho1_deg, -sgn * rho2, -rho1_deg, -sgn * rho2]
    assign = ["M" if r < 0 else "V" for r in rho] + ["B"] * 4
    mats = None if material is None else [material] * 4 + [None] * 4
    return _fold(verts, faces, edges, assign, rho + [0.0] * 4, "degree-4 vertex", mats)


def miura(nx: int = 3, ny: int = 3, width: float = 20.0, height: float = 16.0, shift: float = 6.0,
          zigzag_deg: float = 110.0, materials: dict | None = None) -> dict:
    """A Miura-ori patch of ``nx`` x ``ny`` parallelogram panels (mm): horizontal crease
    lines straight, vertical ones zigzag (every other row shifted by ``shift``).

    Assignment (Maekawa and the small-sector rule at every vertex): zigzag line i is V for
    even i, M for odd i; horizontal segment i on line j has the zigzag's type on odd rows
    and the opposite on even rows. Target angles lie on the patch's one-degree-of-freedom
    folding path: |rho_zigzag| = ``zigzag_deg`` and tan(|rho_h|/2) = cos(gamma) tan(|rho_z|/2)
    with gamma = atan(height / shift) (:func:`degree4_ratio` with alpha = 180 - gamma,
    beta = gamma). ``materials`` maps "zigzag"/"straight" to hinge materials."""
    gamma = math.atan2(height, shift)
    rz = zigzag_deg
    rh = math.degrees(2 * math.atan(math.cos(gamma) * math.tan(math.radians(rz) / 2)))
    vid = {}
    verts = []
    for j in range(ny + 1):
        for i in range(nx + 1):
            vid[i, j] = len(verts)
            verts.append((i * width + (j % 2) * shift, j * height))
    faces = [[vid[i, j], vid[i + 1, j], vid[i + 1, j + 1], vid[i, j + 1]] for j in range(ny) for i in range(nx)]
    edges, assign, angles, kinds = [], [], [], []

    def add(a, b, sign, kind):
        edges.append([vid[a], vid[b]])
        if sign == 0:
            assign.append("B")
            angles.append(0.0)
        else:
            assign.append("V" if sign > 0 else "M")
            angles.append(sign * (rz if kind == "zigzag" else rh))
        kinds.append(kind)

    for j in range(ny + 1):  # horizontal (straight) lines
        for i in range(nx):
            border = j in (0, ny)
            z = 1 if i % 2 == 0 else -1
            add((i, j), (i + 1, j), 0 if border else (z if j % 2 else -z), "straight")
    for i in range(nx + 1):  # zigzag lines
        for j in range(ny):
            border = i in (0, nx)
            add((i, j), (i, j + 1), 0 if border else (1 if i % 2 == 0 else -1), "zigzag")
    mats = None
    if materials:
        mats = [None if a == "B" else materials.get(k) for a, k in zip(assign, kinds)]
    return _fold(verts, faces, edges, assign, angles, f"Miura-ori {nx}x{ny}", mats)


def waterbomb(size: float = 40.0, diagonal_deg: float = 90.0, material: str | None = None) -> dict:
    """A waterbomb base: a square with a degree-8 vertex at its centre, half-midlines
    mountain and half-diagonals valley, all driven to +-``diagonal_deg``. Equal magnitudes
    are not on the pattern's folding paths (it has 5 degrees of freedom); the loop tracker
    finds the nearest closed configuration (-49.0 / +110.6 deg for 90 deg) and reports the
    creases it cannot follow."""
    h = size / 2
    ring = [(h, 0), (h, h), (0, h), (-h, h), (-h, 0), (-h, -h), (0, -h), (h, -h)]
    verts = [(0.0, 0.0)] + ring
    faces = [[0, 1 + k, 1 + (k + 1) % 8] for k in range(8)]
    edges = [[0, 1 + k] for k in range(8)] + [[1 + k, 1 + (k + 1) % 8] for k in range(8)]
    rho = [(-diagonal_deg if k % 2 == 0 else diagonal_deg) for k in range(8)]
    assign = ["M" if r < 0 else "V" for r in rho] + ["B"] * 8
    mats = None if material is None else [material] * 8 + [None] * 8
    return _fold(verts, faces, edges, assign, rho + [0.0] * 8, "waterbomb base", mats)


def hypar(rings: int = 4, size: float = 80.0, pleat_deg: float = 40.0, diagonal_deg: float = 20.0,
          material: str | None = None) -> dict:
    """A pleated hyperbolic paraboloid ("hypar"): a square sheet ``size`` mm wide with
    ``rings`` concentric squares (the outermost is the border) whose creases alternate
    valley (odd squares, counted outward) and mountain at ``pleat_deg``, and both diagonals
    creased: the one through (+x, +y) valley, the other mountain, at ``diagonal_deg``.
    No rigid folding exists (Demaine et al. 2011): the panels twist, and the sheet takes a
    saddle whose sign the diagonals set: a valley line lifts the sheet on both of its
    sides, a mountain line lowers it, so the corners on the mountain diagonal rise and
    those on the valley diagonal sink (``docs/mechanics.md``)."""
    signs = [(1, 1), (-1, 1), (-1, -1), (1, -1)]
    verts = [(0.0, 0.0)]
    cid = {}
    for r in range(1, rings + 1):
        h = size / 2 * r / rings
        for q, (sx, sy) in enumerate(signs):
            cid[r, q] = len(verts)
            verts.append((sx * h, sy * h))
    corner = lambda r, q: 0 if r == 0 else cid[r, q % 4]  # noqa: E731
    faces, edges, assign, angles = [], [], [], []
    for r in range(rings):
        for q in range(4):
            f = [corner(r, q), corner(r + 1, q), corner(r + 1, q + 1)]
            if r > 0:
                f.append(corner(r, q + 1))
            faces.append(f)
    for r in range(1, rings + 1):  # square edges
        for q in range(4):
            edges.append([corner(r, q), corner(r, q + 1)])
            if r == rings:
                assign.append("B")
                angles.append(0.0)
            else:
                v = r % 2 == 1
                assign.append("V" if v else "M")
                angles.append(pleat_deg if v else -pleat_deg)
    for r in range(rings):  # diagonal segments
        for q in range(4):
            edges.append([corner(r, q), corner(r + 1, q)])
            v = q % 2 == 0
            assign.append("V" if v else "M")
            angles.append(diagonal_deg if v else -diagonal_deg)
    mats = None if material is None else [None if a == "B" else material for a in assign]
    return _fold(verts, faces, edges, assign, angles, "pleated hypar", mats)
