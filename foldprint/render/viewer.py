"""The interactive fold viewer: one offline HTML page per design, drawn by three.js.

:func:`viewer_data` turns a simulation into what the page draws: the printed part, not a
sketch of it. Panels are the printed panel solids (thickness, holes, hinge teeth) of
:func:`foldprint.geometry.build_pieces` in the flat state, moved in the browser by the
simulation's panel poses; hinges are ribbons of the printed strip (width, thickness,
segments between slots) bent through :func:`foldprint.physics.kinematics.hinge_map`, evaluated
here, per frame (the page only interpolates between frames, it has no hinge map of its
own). :func:`viewer_page` wraps the data in a page that loads three.js and the viewer
script from ``../viewer/`` (written once by :func:`write_assets`): classic scripts, no
network, so it opens from ``file://``. The printed part is built with arc hinges; a
``point``-model simulation (the paper's ROM, a comparison mode) moves the same panels about
the fold lines, and its ribbons collapse onto them.

The camera follows the part: the data holds each frame's box (``boxes``: every panel
solid and ribbon at that moment) and the page frames the box of the moment shown, so the
flat sheet and the folded part both fill the view (a box over the whole trajectory would
not: on ``helix_uniform`` it is 536 x 349 mm for a folded spiral of 56 x 55 mm, which
then drew at about 80 px). The banner names the run shown: the nominal fold's status, or
the replayed worst sample and its first contact (:func:`worst_banner`).

Size: arrays are base64 (poses float32, ribbon vertices quantised to 16 bits over the
scene's bounds, 1.5 um steps on a 100 mm part). With :data:`FRAMES` frames the templates'
pages are 0.14 MB (self_lock: 6 panels, 5 hinges), 0.24 MB (helix: 10 panels, 9 hinges)
and 0.45 MB (mailbox: 12 panels, 11 hinges in 17 slotted segments, hinge teeth); the
ribbons are most of it. The replayed worst sample (``worst``) adds its own poses and
ribbons: 0.26, 0.45 and 0.81 MB with it. three.js (0.56 MB, MIT licence) is written once,
beside them.
"""

from __future__ import annotations

import base64
import html
import json
from importlib import resources

import numpy as np

from ..core.display import seconds
from ..core.modes import HingeModel, JamReason, State
from ..model.derived import scoped
from ..model.design import Design
from ..physics.kinematics import forward, hinge_frames, hinge_map, target_angles
from ..model import composition
from ..model.materials import MaterialLibrary

FRAMES = 61
"""Frames per fold (evenly spaced over the motion; the page interpolates between them)."""
RIBBON_SECTIONS = 8
"""Bend sections of a hinge ribbon (<= 90 deg / 8 = 11 deg per section for a right fold)."""
FALLBACK_COLOR = "#9a9a9a"
ASSETS = ("three-viewer.min.js", "LICENSE-three.txt", "viewer.js", "viewer.css")
"""Files written once into the gallery's ``viewer/`` directory."""


def _b64(a: np.ndarray, dtype) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype=dtype).tobytes()).decode("ascii")


def _color(lib: MaterialLibrary, name: str) -> str:
    return (lib[name].color if name in lib else FALLBACK_COLOR)[:7]


def _panel_meshes(design: Design) -> list[dict]:
    """Printed panel and teeth solids in the flat sheet, each tied to the panel that moves it."""
    from shapely.geometry import Point

    from ..geometry import build_pieces

    pidx = design.panel_index()
    items = []
    for piece in build_pieces(design, State.PROGRAMMED):
        if piece.kind not in ("panel", "teeth") or piece.solid is None:
            continue
        mesh = piece.solid.to_mesh()
        v = np.asarray(mesh.vert_properties, float)[:, :3]
        f = np.asarray(mesh.tri_verts, np.int64)
        if piece.kind == "panel":
            panel = pidx[piece.owner]
        else:  # teeth sit inside the panel they are printed into
            c = Point(*v[:, :2].mean(axis=0))
            panel = min(range(len(design.panels)), key=lambda k: design.panels[k].polygon.distance(c))
        items.append({"kind": piece.kind, "owner": piece.owner, "material": piece.material,
                      "panel": int(panel), "v": v, "f": f})
    return items


def _ribbons(design: Design, angles: np.ndarray, poses: np.ndarray, model: HingeModel):
    """Ribbon vertices (n_t, n_vertices, 3) of every hinge and the shared triangle list.

    Per hinge segment: RIBBON_SECTIONS + 1 cross-sections across the strip width, each a
    rectangle (two line ends x +-thickness/2) mapped by the parent's pose times the hinge
    map at that fraction of the width."""
    from ..geometry.hinges import hinge_segments

    s = np.linspace(0.0, 1.0, RIBBON_SECTIONS + 1)
    n_t = len(angles)
    verts, tris, owners, n0 = [], [], [], 0
    for fr in hinge_frames(design):
        h = fr.hinge
        a, b = np.asarray(h.line, float)
        d = np.array([*(b - a) / np.linalg.norm(b - a), 0.0])
        start = np.array([a[0], a[1], 0.0]) - 0.5 * fr.width * fr.normal
        # (n_t, n_s, 4, 4): sheet -> world of the strip line at each fraction, at each time
        m = hinge_map(fr, np.repeat(angles[:, fr.index], len(s)), model, np.tile(s, n_t))
        m = poses[:, fr.parent][:, None] @ m.reshape(n_t, len(s), 4, 4)
        for v0, v1 in hinge_segments(h):
            local = []
            for k in range(len(s)):  # corner order per section: (v0,-), (v1,-), (v1,+), (v0,+)
                for v, z in ((v0, -1), (v1, -1), (v1, 1), (v0, 1)):
                    local.append(start + fr.width * s[k] * fr.normal + v * d
                                 + np.array([0.0, 0.0, 0.5 * z * h.thickness]))
            local = np.array(local)  # (n_s * 4, 3)
            sec = np.repeat(np.arange(len(s)), 4)
            ms = m[:, sec]  # (n_t, n_s * 4, 4, 4)
            world = np.einsum("tkij,kj->tki", ms[..., :3, :3], local) + ms[..., :3, 3]
            verts.append(world)
            for k in range(len(s) - 1):
                for c in range(4):
                    p, q = n0 + 4 * k + c, n0 + 4 * k + (c + 1) % 4
                    tris += [(p, q, q + 4), (p, q + 4, p + 4)]
            last = n0 + 4 * (len(s) - 1)
            tris += [(n0, n0 + 2, n0 + 1), (n0, n0 + 3, n0 + 2), (last, last + 1, last + 2),
                     (last, last + 2, last + 3)]
            owners.append((fr.index, n0, 4 * len(s)))
            n0 += 4 * len(s)
    if not verts:
        return np.zeros((n_t, 0, 3)), np.zeros((0, 3), np.int64), []
    return np.concatenate(verts, axis=1), np.array(tris, np.int64), owners


def _contact_point(contact, items: list[dict], poses: np.ndarray) -> list[float]:
    """The contact's point (world, mm); for the 2D index, which has none, the midpoint of
    the closest vertex pair of the two panels' printed solids at the contact pose."""
    p = np.asarray(contact.point, float)
    if np.all(np.isfinite(p)):
        return [float(x) for x in p]
    pts = []
    for k in contact.pair:
        v = np.concatenate([it["v"] for it in items if it["panel"] == k and it["kind"] == "panel"])
        pts.append(v @ poses[k][:3, :3].T + poses[k][:3, 3])
    a, b = pts
    d = ((a[:, None, :] - b[None, :, :]) ** 2).sum(-1)
    i, j = np.unravel_index(int(np.argmin(d)), d.shape)
    return [float(x) for x in 0.5 * (a[i] + b[j])]


def _run_frames(result, frames: int):
    """(times, angles incl. the programmed and permanent states, end) of one simulation."""
    from .scene import motion_end

    design = result.design
    traj = result.trajectory
    end = motion_end(result)
    times = np.linspace(0.0, end, frames)
    angles = np.stack([np.interp(times, traj.times, traj.angles[:, k])
                       for k in range(traj.angles.shape[1])], axis=1) if len(design.hinges) else \
        np.zeros((frames, 0))
    states = np.stack([np.zeros(len(design.hinges)), target_angles(design)])
    return times, np.concatenate([angles, states]), end


def _contacts(result, items: list[dict], model: HingeModel) -> list[dict]:
    design, traj = result.design, result.trajectory
    out = []
    for c in result.contacts:
        k = int(np.clip(np.searchsorted(traj.times, c.time), 0, len(traj.times) - 1))
        out.append({"panels": list(c.panels), "pair": [int(i) for i in c.pair],
                    "time": float(c.time), "method": str(c.method),
                    "point": _contact_point(c, items, forward(design, traj.angles[k:k + 1], model)[0])})
    return out


def worst_text(replay) -> str:
    """Why a replayed sample (:func:`foldprint.apps.replay.worst_sample`) is the worst, in words."""
    o = replay.outcome
    if o.reason == JamReason.COLLISION:
        return f"the earliest first contact of the samples: panels {o.pair[0]}\u2013{o.pair[1]} at {seconds(o.time)}"
    if o.jammed:
        return "jams without a collision (" + ("a goal is not met" if o.reason == JamReason.GOAL
                                               else "a hinge does not reach 98 %") + ")"
    return f"no sample jams; the slowest fold ({seconds(o.fold_time)})"


def worst_banner(replay, samples: int | None = None) -> str:
    """The viewer's banner while it shows a replayed sample: which sample, and its first
    contact (the pair and the time) or how else it ends."""
    res = replay.result
    c = res.first_collision
    head = f"Worst scatter sample, #{replay.index}" + ("" if samples is None else f" of {samples}") + ": "
    if c is not None:
        return head + (f"panels {c.panels[0]}\u2013{c.panels[1]} touch at {seconds(c.time)}, "
                       "the earliest contact of the samples; the printed part jams there.")
    if replay.outcome.jammed:
        return head + worst_text(replay) + "."
    return head + f"no sample jams; this is the slowest fold ({seconds(res.fold_time)})."


def _frame_boxes(rib: np.ndarray, poses: np.ndarray, items: list[dict]) -> np.ndarray:
    """Per frame, the box (lo xyz, hi xyz) around every panel solid and hinge ribbon: what
    the viewer's camera frames at that moment, (n_frames, 6)."""
    lo = rib.min(axis=1) if rib.size else np.full((len(poses), 3), np.inf)
    hi = rib.max(axis=1) if rib.size else np.full((len(poses), 3), -np.inf)
    for it in items:
        q = poses[:, it["panel"]]
        w = np.einsum("tij,nj->tni", q[:, :3, :3], it["v"]) + q[:, None, :3, 3]
        lo, hi = np.minimum(lo, w.min(axis=1)), np.maximum(hi, w.max(axis=1))
    return np.concatenate([lo, hi], axis=1)


def _boxes_json(boxes: np.ndarray) -> list[list[float]]:
    return [[round(float(x), 3) for x in b] for b in boxes]


@scoped
def viewer_data(result, library: MaterialLibrary, robust=None, frames: int = FRAMES, worst=None) -> dict:
    """Everything the page draws, as JSON-ready data.

    Parameters
    ----------
    result : SimulationResult
        The simulation (its trajectory gives the poses; its contacts are marked).
    library : MaterialLibrary
        Material colours and names for the legend.
    robust : object, optional
        A jam-probability result (``.jam_probability``, ``.ci95``, ``.samples``,
        ``.seed``), shown when given.
    frames : int
        Frames over the motion, from the flat sheet to :func:`foldprint.render.scene.motion_end`.
    worst : Replay, optional
        A Monte-Carlo sample folded again (:func:`foldprint.apps.replay.replay_sample`: its
        ``.result``, ``.index``, ``.outcome``), drawn as a second run under ``"worst"``
        that the page can show instead of the nominal fold (same geometry, its own
        times, poses, ribbons and contacts; one quantisation box for both).
    """
    design = result.design
    traj = result.trajectory
    model = str(getattr(traj.model, "value", traj.model))
    runs = [result] + ([] if worst is None else [worst.result])
    framed = [_run_frames(r, frames) for r in runs]
    poses = [forward(design, a, model) for _, a, _ in framed]
    items = _panel_meshes(design)
    ribs = []
    for (_, a, _), p in zip(framed, poses):
        rib, rib_tris, owners = _ribbons(design, a, p, model)
        ribs.append(rib)
    boxes = [_frame_boxes(r, p, items) for r, p in zip(ribs, poses)]
    lo = np.min([b[:, :3].min(axis=0) for b in boxes], axis=0)
    hi = np.max([b[:, 3:].max(axis=0) for b in boxes], axis=0)
    span = np.maximum(hi - lo, 1e-6)

    def quant(rib):
        return np.round((rib - lo) / span * 65535.0).astype(np.uint16) if rib.size else np.zeros(0, np.uint16)

    def col_major(p):  # three.js Matrix4.fromArray is column-major
        return np.swapaxes(p, -1, -2)

    times, _, end = framed[0]
    used = sorted({h.material for h in design.hinges} | {p.material for p in design.panels})
    data = {
        "name": design.name, "model": model, "bath_c": float(traj.bath_c), "end": float(end),
        "after_contact": str(getattr(result.after_contact, "value", result.after_contact)),
        "planar": bool(design.is_planar_strip), "frames": int(frames), "times": [float(t) for t in times],
        "panels": [{"id": p.id, "material": p.material} for p in design.panels],
        "hinges": [{"id": h.id, "material": h.material, "panels": list(h.panels),
                    "angle_deg": float(np.degrees(h.angle))} for h in design.hinges],
        "colors": {m: _color(library, m) for m in used},
        "items": [{"kind": it["kind"], "owner": it["owner"], "material": it["material"],
                   "panel": it["panel"], "v": _b64(it["v"], "<f4"), "f": _b64(it["f"], "<u4")}
                  for it in items],
        "poses": _b64(col_major(poses[0]), "<f4"),
        "ribbon": {"q": _b64(quant(ribs[0]), "<u2"), "f": _b64(rib_tris, "<u4"), "n": int(ribs[0].shape[1]),
                   "owners": [[int(a), int(b), int(c)] for a, b, c in owners]},
        "bounds": [[float(x) for x in lo], [float(x) for x in hi]],
        "boxes": _boxes_json(boxes[0]),
        "contacts": _contacts(result, items, model),
        "completed": bool(result.completed),
        "robust": None if robust is None else {
            "jam_probability": float(robust.jam_probability),
            "ci95": [float(x) for x in robust.ci95],
            "samples": int(robust.samples), "seed": int(robust.seed)},
        "worst": None,
        "mechanics": _mechanics(result),
    }
    if worst is not None:
        data["worst"] = _worst_run(worst, framed[1], col_major(poses[1]), quant(ribs[1]), items, model)
        data["worst"]["boxes"] = _boxes_json(boxes[1])
        data["worst"]["banner"] = worst_banner(worst, None if robust is None else int(robust.samples))
    ramp = composition.ramp_legend(used)  # only when a hinge names a VeroWhite fraction
    if ramp is not None:
        data["ramp"] = ramp
    return data


def _mechanics(result) -> dict | None:
    """A bar-and-hinge run's largest panel strain and diagonal fold per solved step (the
    page's clock shows them), None for rigid mechanics."""
    sol = getattr(result, "compliant", None)
    if sol is None:
        return None
    return {"times": [float(t) for t in sol.grid],
            "strain": [float(v) for v in sol.panel_strain.max(axis=1, initial=0.0)],
            "bending_deg": [float(np.degrees(v)) for v in sol.panel_bending.max(axis=1, initial=0.0)],
            "max_strain": sol.max_strain, "max_bending_deg": float(np.degrees(sol.max_bending)),
            "limit": sol.strain_limit}


def _worst_run(worst, framed, poses_cm: np.ndarray, q: np.ndarray, items, model: str) -> dict:
    """The worst sample's run for the page: its times, column-major poses, quantised
    ribbons and contacts."""
    w = worst.result
    w_times, _, w_end = framed
    return {"sample": int(worst.index), "why": worst_text(worst), "bath_c": float(w.trajectory.bath_c),
            "end": float(w_end), "times": [float(t) for t in w_times], "completed": bool(w.completed),
            "poses": _b64(poses_cm, "<f4"), "q": _b64(q, "<u2"), "contacts": _contacts(w, items, model)}


_PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="generator" content="foldprint {version}">
<title>{title}</title>
<link rel="stylesheet" href="../viewer/viewer.css">
</head>
<body>
<header><a href="{back}">&larr; gallery</a><h1>{name}</h1><p class="status {cls}" id="banner">{status}</p></header>
<main id="viewer">
<div id="stage"><canvas id="view" width="960" height="540" aria-label="3D view of {name} folding"></canvas>
<noscript><p>The 3D viewer needs JavaScript; the gallery page has still pictures of this design.</p></noscript></div>
<div id="controls">
<button id="play" type="button">&#9654; play</button>
<div id="track"><input id="slider" type="range" min="0" max="1000" step="1" value="0" aria-label="time"><div id="marks"></div></div>
<span id="clock">t = 0.00 s</span>
<span class="states"><button id="programmed" type="button">programmed</button><button id="permanent" type="button">permanent</button></span>
<span class="runs" id="runs"></span>
<button id="follow" type="button" aria-pressed="true" title="the camera frames the part at every moment of the fold">follow the part</button>
</div>
<div id="info"><div id="legend"></div><div id="facts"></div></div>
<p class="muted">Drag to orbit, scroll to zoom, right-drag to pan. The camera follows the part (it frames every
moment of the fold, from the flat sheet to the folded part) until you zoom or pan; <em>follow the part</em> turns it back on. The address ends in <code>#t=</code> the
fraction of the fold shown (0 = flat, 1 = end of the motion), or <code>#state=</code> programmed or permanent,
after <code>#run=worst&amp;</code> for the worst Monte-Carlo sample where there is one: copy it to link this view.
Drawn with three.js (MIT licence, <a href="../viewer/LICENSE-three.txt">LICENSE-three.txt</a>).</p>
</main>
<script type="application/json" id="fold-data">{data}</script>
<script src="../viewer/three-viewer.min.js"></script>
<script src="../viewer/viewer.js"></script>
</body>
</html>
"""


def viewer_page(data: dict, status: str, ok: bool, back: str, version: str) -> str:
    """The HTML of one design's viewer page (scripts and styles from ``../viewer/``)."""
    e = lambda s: html.escape(str(s), quote=True)  # noqa: E731
    blob = json.dumps(data, separators=(",", ":"), ensure_ascii=True, allow_nan=False)
    blob = blob.replace("</", "<\\/")  # no "</script>" inside the data block
    return _PAGE.format(version=e(version), title=e(f"{data['name']}: fold viewer (foldprint)"),
                        back=e(back), name=e(data["name"]), cls="ok" if ok else "fail",
                        status=e(status), data=blob)


def asset_bytes(name: str) -> bytes:
    """One of :data:`ASSETS`, from the package data."""
    return resources.files("foldprint").joinpath("data", "viewer", name).read_bytes()
