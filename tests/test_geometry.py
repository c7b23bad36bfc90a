"""Solids: watertight per-material bodies, disjoint, volume-true, for every template and
for random designs (hypothesis)."""

from __future__ import annotations

import itertools
import math
from dataclasses import replace
from functools import lru_cache
from pathlib import Path

import manifold3d as mf
import numpy as np
import pytest
import shapely
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from shapely.geometry import MultiPoint, Polygon

from foldprint.model.design import Design, Hinge, HingeStyle, Panel, strip, validate
from foldprint.io.load import load_design
from foldprint.core.errors import GeometryError
from foldprint.geometry import (BEND_VOLUME_RATIO_MIN, STATES, TEETH_OVERLAP, arc_transform, build_assembly,
                                build_pieces, hinge_segments, layout, panel_solids, strip_profile)
from foldprint.model.design import has_loops, tangent_factor
from foldprint.physics.kinematics import hinge_frames, local_transforms

TEMPLATES = sorted((Path(__file__).resolve().parent.parent / "templates").glob("*.toml"))
TEMPLATE_IDS = [p.stem for p in TEMPLATES]
#: Templates whose printed (permanent) shape is known not to build, with the finding.
#: strict: the entry must go once the template is fixed.
KNOWN_UNPRINTABLE: dict[str, str] = {
    # a loop pattern whose targets are off its folding path (docs/loops.md): the jam demo
    "cross_lock_uniform": "its targets (all four creases 90 deg) do not close the loop",
}


def _known(path, state="permanent"):
    reason = KNOWN_UNPRINTABLE.get(Path(path).stem)
    if reason and state == "permanent":
        pytest.xfail(reason)  # checked below: the build really fails with that overlap


@lru_cache(maxsize=None)
def _design(path: str) -> Design:
    return load_design(path)


@lru_cache(maxsize=None)
def _assembly(path: str, state: str):
    return build_assembly(_design(path), state)


def _manifold(body) -> mf.Manifold:
    m = body.to_manifold()
    assert m.status() == mf.Error.NoError
    return m


def assert_valid(assembly, rel_overlap: float = 1e-6) -> None:
    """Every body watertight, consistently wound, positive volume; bodies disjoint."""
    assert assembly.bodies, "no bodies"
    total = assembly.volume
    for b in assembly.bodies:
        tm = trimesh.Trimesh(b.vertices, b.faces, process=True)
        assert tm.is_watertight, f"{b.material} body is not watertight"
        assert tm.is_winding_consistent, f"{b.material} body winding is inconsistent"
        assert b.volume > 0
        assert tm.volume == pytest.approx(b.volume, rel=1e-9)
    solids = [_manifold(b) for b in assembly.bodies]
    for (a, ma), (b, mb) in itertools.combinations(zip(assembly.bodies, solids), 2):
        inter = (ma ^ mb).volume()
        assert inter < rel_overlap * total, f"{a.material} and {b.material} overlap by {inter:g} mm^3"


# -- every template, both states ------------------------------------------------------

def test_templates_exist():
    names = {p.stem for p in TEMPLATES}
    assert {"mailbox", "mailbox_reversed"} <= names


@pytest.mark.parametrize("state", STATES)
@pytest.mark.parametrize("path", TEMPLATES, ids=TEMPLATE_IDS)
def test_template_bodies_valid_and_disjoint(path, state):
    _known(path, state)
    asm = _assembly(str(path), state)
    assert asm.state == state and asm.design_name == _design(str(path)).name
    assert len(asm.bodies) == len(_design(str(path)).materials_used)
    assert_valid(asm)


@pytest.mark.parametrize("path", TEMPLATES, ids=TEMPLATE_IDS)
def test_template_volume_same_in_both_states(path):
    """Bending a strip of uniform curvature about its mid-surface keeps its volume: the
    annular sector of radii R -+ t/2 and angle phi holds R t phi = t w per unit length.
    Every slice of the printed mesh replaces arcs by chords and keeps sin(a)/a of it;
    slices are <= 5 deg, so a hinge body loses at most 1 - sin(5 deg)/(5 deg) = 0.127 %
    and never gains. Panels are rigid: equal to rounding. A hinge of a pattern with loops is
    printed as the tangent arc, f = (rho/2)/tan(rho/2) of its flat length
    (docs/loops.md), so its body keeps f of the flat volume (between the smallest and the
    largest f of that material's hinges)."""
    _known(path)
    perm = _assembly(str(path), "permanent")
    prog = _assembly(str(path), "programmed")
    assert perm.materials == prog.materials
    design = _design(str(path))
    for a, b in zip(perm.bodies, prog.bodies):
        ratio = a.volume / b.volume
        fs = [float(tangent_factor(h.angle)) if has_loops(design) else 1.0
              for h in design.hinges if h.material == a.material] or [1.0]
        assert min(fs) * BEND_VOLUME_RATIO_MIN - 1e-9 <= ratio <= max(fs) + 1e-9, (a.material, ratio, fs)
    for m in {p.material for p in design.panels} - {h.material for h in design.hinges}:
        assert perm.body(m).volume == pytest.approx(prog.body(m).volume, rel=1e-9)


@pytest.mark.parametrize("path", TEMPLATES, ids=TEMPLATE_IDS)
def test_template_nonadjacent_panels_disjoint_when_folded(path):
    """Panels that fold against each other must not interpenetrate in the printed state;
    the mailbox corners keep >= 0.5 mm."""
    _known(path)
    design = _design(str(path))
    solids = panel_solids(design, "permanent")
    adjacent = {frozenset(h.panels) for h in design.hinges}
    min_gap = math.inf
    for (a, ma), (b, mb) in itertools.combinations(solids.items(), 2):
        if frozenset((a, b)) in adjacent:
            continue
        assert (ma ^ mb).volume() < 1e-9, f"panels {a} and {b} interpenetrate"
        min_gap = min(min_gap, ma.min_gap(mb, 2.0))
    if design.name.startswith("mailbox"):
        assert min_gap >= 0.5, min_gap
        assert min_gap < 2.0  # the search window found the tight corner (lid over the walls)


@pytest.mark.parametrize("name", sorted(KNOWN_UNPRINTABLE))
def test_known_unprintable_templates_still_fail(name):
    """Keeps KNOWN_UNPRINTABLE honest: remove an entry when its template is fixed."""
    path = [p for p in TEMPLATES if p.stem == name]
    if not path:
        pytest.skip(f"template {name} is gone")
    with pytest.raises(GeometryError, match="overlap"):
        build_assembly(_design(str(path[0])), "permanent")
    assert_valid(_assembly(str(path[0]), "programmed"))


@pytest.mark.parametrize("path", TEMPLATES, ids=TEMPLATE_IDS)
def test_rigid_parts_match_the_collision_model(path):
    """The printed panels (plus the teeth in their notches) are exactly the rigid parts
    the collision checks use under the arc model (``foldprint.collision.rigid``)."""
    from foldprint.collision.rigid import rigid_polygon

    design = _design(str(path))
    lays, rigid = layout(design)
    for k, panel in enumerate(design.panels):
        teeth = [lay.teeth[k] for lay in lays if k in lay.teeth]
        printed = shapely.union_all([rigid[k], *teeth])
        model = rigid_polygon(design, k, "arc")
        assert printed.area == pytest.approx(model.area, rel=1e-9), panel.id
        assert printed.symmetric_difference(model).area < 1e-9 * model.area + 1e-9, panel.id


def test_build_is_deterministic():
    path = str(TEMPLATES[TEMPLATE_IDS.index("mailbox")])
    a = build_assembly(_design(path), "permanent")
    b = build_assembly(_design(path), "permanent")
    for x, y in zip(a.bodies, b.bodies):
        assert x.material == y.material
        assert np.array_equal(x.vertices, y.vertices) and np.array_equal(x.faces, y.faces)
        assert x.volume == y.volume
    assert not a.bodies[0].vertices.flags.writeable


# -- the mailbox templates -----------------------------------------------------------------

def test_mailbox_hinge_groups_and_styles():
    box = _design(str(TEMPLATES[TEMPLATE_IDS.index("mailbox")]))
    rev = _design(str(TEMPLATES[TEMPLATE_IDS.index("mailbox_reversed")]))
    groups = {h.id: h.material for h in box.hinges}
    assert {groups[k] for k in groups if k.startswith("tab")} == {"H-3"}
    assert {groups[k] for k in ("front", "back", "lid")} == {"H-6"}
    assert {groups[k] for k in ("left", "right")} == {"H-5"}
    assert len(groups) == 9
    swap = {"H-3": "H-6", "H-6": "H-3", "H-5": "H-5"}
    for h, r in zip(box.hinges, rev.hinges):
        assert r.id == h.id and r.material == swap[h.material]
        assert np.array_equal(r.line, h.line) and r.angle == h.angle and r.radius == h.radius
        assert r.style == h.style
    for p, q in zip(box.panels, rev.panels):
        assert np.array_equal(p.outline, q.outline)
    for h in box.hinges:
        assert h.thickness == 1.6 and h.style.thin_mm == 0.8  # thick and thin steps (template header)
        assert h.style.stepped and h.style.interface == "triangular"
        n_seg = len(hinge_segments(h))
        assert n_seg == (1 if h.id.startswith("tab") else (math.ceil(h.length / 13.0)))
        assert n_seg > 1 or h.id.startswith("tab")


# -- analytic checks ------------------------------------------------------------------------

def _square_with_hole() -> Design:
    outline = [[0, 0], [30, 0], [30, 20], [0, 20]]
    hole = np.array([[5, 5], [5, 10], [12, 10], [12, 5]], float)  # clockwise on purpose
    return validate(Design("flat", (Panel("p", outline, 1.25, "VeroWhite", (hole,)),), ()))


@pytest.mark.parametrize("state", STATES)
def test_single_flat_panel_volume_is_area_times_thickness(state):
    asm = build_assembly(_square_with_hole(), state)
    (body,) = asm.bodies
    assert body.volume == pytest.approx((600 - 35) * 1.25, rel=1e-12)
    assert np.allclose(asm.bounds, [[0, 0, -0.625], [30, 20, 0.625]])
    assert_valid(asm)


def _two_panels(angle=90.0, radius=5.0, style=HingeStyle(), t=1.0, th=0.8, depth=10.0) -> Design:
    return strip("two", [20.0, 20.0], [angle], ["H-2"], depth=depth, thickness=t, radius=radius,
                 hinge_thickness=th, style=style)


@pytest.mark.parametrize("angle", [90.0, -135.0, 180.0, 10.0])
def test_bent_hinge_volume_is_chord_exact(angle):
    d = _two_panels(angle)
    h = d.hinges[0]
    asm = build_assembly(d, "permanent")
    n = math.ceil(abs(math.radians(angle)) / math.radians(5) - 1e-9)
    dphi = abs(math.radians(angle)) / n
    expect = h.length * h.thickness * h.width * math.sin(dphi) / dphi
    assert asm.body("H-2").volume == pytest.approx(expect, rel=1e-9)
    flat = build_assembly(d, "programmed").body("H-2").volume
    assert flat == pytest.approx(h.length * h.thickness * h.width, rel=1e-12)
    panel = (40 * 10 - h.width * 10) * 1.0
    assert asm.body("VeroWhite").volume == pytest.approx(panel, rel=1e-9)


def test_strip_follows_the_arc_model():
    """The strip's end meets the child exactly where kinematics puts it; its surfaces lie
    on circles of radius R -+ t/2 about the bend axis."""
    d = _two_panels(120.0, radius=4.0)
    (f,) = hinge_frames(d)
    rho = d.hinges[0].angle
    assert np.array_equal(arc_transform(f, rho, 0.0), np.eye(4))
    assert np.allclose(arc_transform(f, rho, f.width), local_transforms(f, np.array([rho]), "arc")[0],
                       atol=1e-12)
    strip_piece = [p for p in build_pieces(d, "permanent") if p.kind == "strip"][0]
    mesh = strip_piece.solid.to_mesh64()
    v = np.asarray(mesh.vert_properties)[:, :3]
    # arc centre: start of the strip + R * z (valley fold), axis along the fold line (y)
    centre = f.origin - 0.5 * f.width * f.normal + np.array([0, 0, 4.0])
    r = np.hypot(v[:, 0] - centre[0], v[:, 2] - centre[2])
    assert np.all((np.abs(r - 3.6) < 1e-9) | (np.abs(r - 4.4) < 1e-9))
    child = [p for p in build_pieces(d, "permanent") if p.kind == "panel" and p.owner == "p2"][0]
    assert child.solid.min_gap(strip_piece.solid, 1.0) < 1e-9
    assert (child.solid ^ strip_piece.solid).volume() < 1e-9


def test_stepped_profile():
    style = HingeStyle(stepped=True, step_period_mm=2.0, thin_mm=0.3)
    d = _two_panels(90.0, radius=5.0, style=style)
    h = d.hinges[0]
    u, thick = strip_profile(h, h.angle)
    assert u[0] == 0 and u[-1] == pytest.approx(h.width)
    assert set(np.round(thick, 12)) == {0.3, 0.8}
    assert thick[0] == thick[-1] == 0.8  # thick ends join the panels fully
    n_per = round(h.width / 2.0)
    thin_width = np.sum(np.diff(u)[thick < 0.5])
    assert thin_width == pytest.approx(h.width / 2, rel=1e-12)
    assert np.max(np.diff(u)) * abs(h.angle) / h.width <= math.radians(5) + 1e-12
    flat = build_assembly(d, "programmed").body("H-2").volume
    assert flat == pytest.approx(h.length * h.width * (0.8 + 0.3) / 2, rel=1e-12)
    tm = trimesh.Trimesh(*(lambda b: (b.vertices, b.faces))(build_assembly(d, "permanent").body("H-2")))
    assert tm.is_watertight and n_per >= 3


def test_slots_cut_long_hinges_into_segments():
    style = HingeStyle(max_segment_mm=9.0, slot_width_mm=1.5)
    d = _two_panels(90.0, style=style, depth=30.0)
    segs = hinge_segments(d.hinges[0])
    assert len(segs) == 3
    lengths = [b - a for a, b in segs]
    assert max(lengths) <= 9.0 and lengths == pytest.approx([9.0] * 3)
    gaps = [segs[i + 1][0] - segs[i][1] for i in range(2)]
    assert gaps == pytest.approx([1.5, 1.5])
    body = build_assembly(d, "permanent").body("H-2")
    parts = trimesh.Trimesh(body.vertices, body.faces).split(only_watertight=True)
    assert len(parts) == 3
    assert hinge_segments(_two_panels(90.0, style=HingeStyle(max_segment_mm=40.0)).hinges[0]) == [(0.0, 10.0)]


def _strip_volume(hinge, rho) -> float:
    """Exact volume of the printed strip mesh: chord slices keep sin(a)/a."""
    u, thick = strip_profile(hinge, rho)
    du = np.diff(u)
    dphi = abs(rho) * du / hinge.width
    sinc = np.where(dphi > 0, np.sin(dphi) / np.where(dphi > 0, dphi, 1), 1.0)
    seg = sum(b - a for a, b in hinge_segments(hinge))
    return float(seg * np.sum(thick * du * sinc))


@pytest.mark.parametrize("state", STATES)
def test_triangular_interface_shares_surfaces_without_gap_or_overlap(state):
    """Teeth added to the hinge are exactly the notches cut from the panels: the part's
    volume is the panels' rigid area (before notching) times thickness plus the strip."""
    tri = HingeStyle(interface="triangular", tooth_depth_mm=1.5, tooth_pitch_mm=3.0)
    d = _two_panels(90.0, style=tri, th=0.8, t=1.2, depth=20.0)
    toothed = build_assembly(d, state)
    assert_valid(toothed)
    h = d.hinges[0]
    lays, rigid = layout(d)
    teeth_area = sum(g.area for g in lays[0].teeth.values())
    assert len(lays[0].teeth) == 2 and teeth_area > 0
    panel_area = sum(p.area for p in d.panels) - h.width * h.length
    assert sum(r.area for r in rigid) + teeth_area == pytest.approx(panel_area, rel=1e-12)
    rho = h.angle if state == "permanent" else 0.0
    assert toothed.body("VeroWhite").volume == pytest.approx((panel_area - teeth_area) * 1.2, rel=1e-9)
    # the teeth solids reach TEETH_OVERLAP into the strip (so the two merge robustly);
    # with panels thicker than the hinge that band stands proud of the strip by the difference
    band = sum(g.area for g in lays[0].teeth_solid.values()) - teeth_area
    assert band == pytest.approx(TEETH_OVERLAP * 2 * 6 * 3.0, rel=1e-9)  # 2 rows of 6 teeth
    expect = teeth_area * 1.2 + _strip_volume(h, rho) + band * (1.2 - 0.8)
    # (bent: the band is flat in the panel's frame, the strip's 10 um end slice a chord
    # 0.1 deg off it; the band's share of the strip differs by ~1e-8 of the volume)
    assert toothed.body("H-2").volume == pytest.approx(expect, rel=1e-7)
    if state == "programmed":
        plain = build_assembly(_two_panels(90.0, th=0.8, t=1.2, depth=20.0), state)
        assert toothed.volume == pytest.approx(plain.volume + band * (1.2 - 0.8), rel=1e-12)
    hinge, panels = toothed.body("H-2").to_manifold(), toothed.body("VeroWhite").to_manifold()
    assert hinge.min_gap(panels, 1.0) < 1e-9  # they touch
    tm = trimesh.Trimesh(toothed.body("H-2").vertices, toothed.body("H-2").faces)
    assert len(tm.split(only_watertight=True)) == 1  # teeth merged with the strip


def test_thicker_panels_than_hinge_with_teeth_and_steps_and_slots():
    style = HingeStyle(stepped=True, interface="triangular", max_segment_mm=8.0)
    d = strip("three", [15.0, 18.0, 15.0], [90.0, -160.0], ["H-1", "H-7"], depth=25.0,
              thickness=1.2, hinge_thickness=0.8, radius=[5.0, 3.0], style=style)
    for state in STATES:
        assert_valid(build_assembly(d, state))


# -- errors -------------------------------------------------------------------------------------

def test_overlapping_strips_raise():
    d = strip("short", [20.0, 6.0, 20.0], [90.0, 90.0], ["H-1", "H-1"], radius=5.0)
    with pytest.raises(GeometryError, match="overlap"):
        build_assembly(d, "permanent")


def test_radius_below_half_thickness_raises():
    d = _two_panels(90.0, radius=0.3, th=0.8)
    with pytest.raises(GeometryError, match="radius"):
        build_assembly(d)


def test_unknown_state_raises():
    with pytest.raises(GeometryError, match="state"):
        build_assembly(_two_panels(), "folded")


def test_colliding_permanent_state_raises():
    """A spiral whose third panel folds back into the first cannot be printed."""
    d = strip("clash", [20.0, 12.0, 20.0], [150.0, 150.0], ["H-1", "H-1"], radius=2.0)
    with pytest.raises(GeometryError, match="overlap"):
        build_assembly(d, "permanent")
    assert_valid(build_assembly(d, "programmed"))


# -- property tests ---------------------------------------------------------------------------

def _rotate(points, theta, shift):
    c, s = math.cos(theta), math.sin(theta)
    p = np.asarray(points, float)
    return np.column_stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1]]) + shift


def _end_panel(draw, side: float, x0: float, y0: float, y1: float, reach: float) -> list:
    """A random convex panel on one side of the fold edge x = x0, y in [y0, y1], staying
    within the edge's y-extent and reaching at least ``reach`` from it."""
    k = draw(st.integers(1, 4))
    pts = [(x0, y0), (x0, y1)]
    for _ in range(k):
        dx = draw(st.floats(reach, reach + 15.0))
        pts.append((x0 + side * dx, draw(st.floats(y0, y1))))
    pts.append((x0 + side * draw(st.floats(reach, reach + 15.0)), draw(st.floats(y0, y1))))
    hull = MultiPoint(pts).convex_hull
    assert isinstance(hull, Polygon)
    return [list(c) for c in hull.exterior.coords[:-1]]


styles = st.builds(
    HingeStyle, stepped=st.booleans(), step_period_mm=st.floats(1.0, 4.0), thin_mm=st.floats(0.2, 0.5),
    interface=st.sampled_from(["flat", "triangular"]), tooth_depth_mm=st.floats(0.5, 2.0),
    tooth_pitch_mm=st.floats(1.5, 4.0), max_segment_mm=st.sampled_from([0.0, 6.0, 9.0]),
    slot_width_mm=st.floats(0.5, 1.5))


@st.composite
def random_designs(draw):
    n_hinges = draw(st.integers(1, 2))
    t_panel = draw(st.floats(0.6, 1.2))
    t_hinge = draw(st.floats(0.4, 1.0))
    radii = [draw(st.floats(max(1.0, t_panel), 8.0)) for _ in range(n_hinges)]
    mags = [draw(st.floats(10.0, 180.0)) for _ in range(n_hinges)]
    signs = [draw(st.sampled_from([-1.0, 1.0])) for _ in range(n_hinges)]
    if n_hinges == 2:  # collision-free families: a U (same signs, <= 180 in all) or a Z
        if signs[0] == signs[1]:
            total = sum(mags)
            mags = [m * min(1.0, 180.0 / total) for m in mags]
        else:
            mags = [min(m, 90.0) for m in mags]
    angles = [s * m for s, m in zip(signs, mags)]
    widths = [r * math.radians(abs(a)) for r, a in zip(radii, angles)]
    style = draw(styles)
    reach = [w / 2 + style.tooth_depth_mm + 1.0 for w in widths]
    edges = []  # fold edges x = X_i, y in [y0_i, y1_i]
    x = 0.0
    for i in range(n_hinges):
        if i:
            x += reach[i - 1] + reach[i] + draw(st.floats(0.5, 10.0))
        y0 = draw(st.floats(-3.0, 3.0))
        edges.append((x, y0, y0 + draw(st.floats(6.0, 30.0))))
    theta = draw(st.floats(0, 2 * math.pi))
    shift = np.array([draw(st.floats(-50, 50)), draw(st.floats(-50, 50))])
    outlines = [_end_panel(draw, -1.0, edges[0][0], edges[0][1], edges[0][2], reach[0])]
    for i in range(1, n_hinges):
        (xa, a0, a1), (xb, b0, b1) = edges[i - 1], edges[i]
        outlines.append([[xa, a0], [xb, b0], [xb, b1], [xa, a1]])
    xe, e0, e1 = edges[-1]
    outlines.append(_end_panel(draw, 1.0, xe, e0, e1, reach[-1]))
    mats = draw(st.lists(st.sampled_from(["H-1", "H-4", "H-7"]), min_size=n_hinges, max_size=n_hinges))
    panels = tuple(Panel(f"p{i}", _rotate(o, theta, shift), t_panel, "VeroWhite")
                   for i, o in enumerate(outlines))
    hinges = tuple(Hinge(f"h{i}", (f"p{i}", f"p{i + 1}"), _rotate([[e[0], e[1]], [e[0], e[2]]], theta, shift),
                         math.radians(angles[i]), mats[i], radii[i], t_hinge, style=style)
                   for i, e in enumerate(edges))
    return validate(Design("random", panels, hinges))


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(random_designs())
def test_random_designs_give_valid_disjoint_bodies(design):
    perm = build_assembly(design, "permanent")
    prog = build_assembly(design, "programmed")
    assert_valid(perm)
    assert_valid(prog)
    for a, b in zip(perm.bodies, prog.bodies):
        assert BEND_VOLUME_RATIO_MIN - 1e-9 <= a.volume / b.volume <= 1 + 1e-9


@settings(max_examples=20, deadline=None)
@given(w=st.floats(5.0, 60.0), h=st.floats(5.0, 60.0), t=st.floats(0.2, 3.0), theta=st.floats(0, 6.3))
def test_random_rectangle_panel_volume(w, h, t, theta):
    outline = _rotate([[0, 0], [w, 0], [w, h], [0, h]], theta, np.zeros(2))
    d = validate(Design("rect", (Panel("p", outline, t, "VeroWhite"),), ()))
    (body,) = build_assembly(d).bodies
    assert body.volume == pytest.approx(w * h * t, rel=1e-9)


def test_replace_keeps_design_frozen():
    d = _two_panels()
    d2 = replace(d, hinges=(replace(d.hinges[0], angle=math.radians(45)),))
    assert build_assembly(d2).body("H-2").volume < build_assembly(d).body("H-2").volume
