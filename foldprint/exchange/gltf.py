"""Any 3D viewer: the fold as an animated glTF 2.0 binary (``.glb``), built with pygltflib.

* One node per panel (its rigid part) and per hinge segment (the strip's mid-surface
  between slots), all roots of the one scene, named ``panel <id>`` and
  ``hinge <id> [<segment>]``; one material per design material, coloured from the
  material library (double-sided: the surfaces have no thickness).
* Keyframes are the simulation's time steps (seconds, linear interpolation). A panel
  moves rigidly: its node is animated by a ``rotation`` and a ``translation`` channel
  (glTF animates TRS components separately; an arc hinge turns the child about a point
  that itself moves, so no single component carries the motion). A hinge segment bends:
  its mesh has one morph target per keyframe after the first (the segment's shape then,
  relative to the first), driven by a ``weights`` channel that is one-hot at each
  keyframe, so linear interpolation between keyframes blends two neighbouring shapes.
  Nodes that do not move (the root panel) get no channel.
* Axes and units: glTF is +Y up in metres; the sheet frame is +Z up in mm, so points map
  (x, y, z) mm -> (x, z, -y) / 1000 m.
"""

from __future__ import annotations

import numpy as np
import pygltflib as gl
from scipy.spatial.transform import Rotation

from ..core.version import __version__
from ..geometry.surfaces import Frames
from ..model.design import Design
from ..model.materials import MaterialLibrary

#: sheet frame (mm, +Z up) -> glTF (m, +Y up): a proper rotation and a scale
AXES = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
SCALE = 1e-3
#: two poses closer than this (mm, rad) are the same: the node does not move
STILL = 1e-9


class _Blob:
    """One binary buffer; every array is a 4-byte aligned buffer view and an accessor."""

    def __init__(self, doc: gl.GLTF2):
        self.doc, self.data = doc, bytearray()

    def add(self, arr: np.ndarray, kind: str, target: int | None = None, minmax: bool = False) -> int:
        arr = np.ascontiguousarray(arr)
        ctype = gl.UNSIGNED_INT if arr.dtype == np.uint32 else gl.FLOAT
        offset = len(self.data)
        self.data += arr.tobytes()
        self.data += b"\0" * (-len(self.data) % 4)
        self.doc.bufferViews.append(gl.BufferView(buffer=0, byteOffset=offset, byteLength=arr.nbytes,
                                                  target=target))
        count = arr.shape[0] if kind != "SCALAR" or arr.ndim == 1 else arr.size
        acc = gl.Accessor(bufferView=len(self.doc.bufferViews) - 1, componentType=ctype, count=int(count),
                          type=kind)
        if minmax:
            flat = arr.reshape(int(count), -1)
            acc.min = flat.min(axis=0).astype(float).tolist()
            acc.max = flat.max(axis=0).astype(float).tolist()
        self.doc.accessors.append(acc)
        return len(self.doc.accessors) - 1


def _to_gltf(points: np.ndarray) -> np.ndarray:
    return (points @ AXES.T * SCALE).astype(np.float32)


def glb_bytes(design: Design, frames: Frames, library: MaterialLibrary) -> tuple[bytes, dict]:
    """The animated GLB of ``frames`` (the surfaces placed at every time step) and its
    record fields (nodes, moving nodes, keyframes, channels)."""
    surfaces, times, poses = frames.surfaces, frames.times, frames.poses
    doc = gl.GLTF2(asset=gl.Asset(version="2.0", generator=f"foldprint {__version__}"))
    blob = _Blob(doc)
    mats = list(dict.fromkeys(s.material for s in surfaces))
    for m in mats:
        rgba = list(library[m].rgba) if m in library else [0.5, 0.5, 0.5, 1.0]
        doc.materials.append(gl.Material(name=m, doubleSided=True, alphaMode="OPAQUE",
                                         pbrMetallicRoughness=gl.PbrMetallicRoughness(
                                             baseColorFactor=rgba[:3] + [1.0], metallicFactor=0.0,
                                             roughnessFactor=0.8)))
    t_acc = blob.add(times.astype(np.float32), "SCALAR", minmax=True)
    anim = gl.Animation(name=f"{design.name} fold", samplers=[], channels=[])
    n_t = len(times)
    moving = []
    for s, world in zip(surfaces, frames.points):
        name = f"panel {s.owner}" if s.kind == "panel" else f"hinge {s.owner} [{s.segment}]"
        idx = blob.add(s.triangles.astype(np.uint32).ravel(), "SCALAR", gl.ELEMENT_ARRAY_BUFFER)
        node = gl.Node(name=name)
        if s.kind == "panel":
            pos = blob.add(_to_gltf(s.flat), "VEC3", gl.ARRAY_BUFFER, minmax=True)
            prim = gl.Primitive(attributes=gl.Attributes(POSITION=pos), indices=idx,
                                material=mats.index(s.material))
            doc.meshes.append(gl.Mesh(name=name, primitives=[prim]))
            pose = poses[:, s.index]
            rot = np.einsum("ij,tjk,lk->til", AXES, pose[:, :3, :3], AXES)
            quat = Rotation.from_matrix(rot).as_quat()  # x, y, z, w: glTF's order
            flip = np.cumprod(np.where(np.einsum("ti,ti->t", quat[1:], quat[:-1]) < 0, -1.0, 1.0))
            quat[1:] *= flip[:, None]  # shortest arcs between keyframes
            trans = (pose[:, :3, 3] @ AXES.T) * SCALE
            node.rotation = quat[0].tolist()
            node.translation = trans[0].tolist()
            if np.ptp(pose[:, :3, :], axis=0).max() > STILL:
                for path, values, kind in (("rotation", quat, "VEC4"), ("translation", trans, "VEC3")):
                    out = blob.add(values.astype(np.float32), kind)
                    anim.samplers.append(gl.AnimationSampler(input=t_acc, output=out, interpolation="LINEAR"))
                    anim.channels.append(gl.AnimationChannel(
                        sampler=len(anim.samplers) - 1,
                        target=gl.AnimationChannelTarget(node=len(doc.nodes), path=path)))
                moving.append(name)
        else:
            # world: (n_t, n, 3) mm
            base = _to_gltf(world[0])
            pos = blob.add(base, "VEC3", gl.ARRAY_BUFFER, minmax=True)
            prim = gl.Primitive(attributes=gl.Attributes(POSITION=pos), indices=idx,
                                material=mats.index(s.material))
            mesh = gl.Mesh(name=name, primitives=[prim])
            if np.ptp(world, axis=0).max() > STILL and n_t > 1:
                prim.targets = [gl.Attributes(POSITION=blob.add(_to_gltf(world[k]) - base, "VEC3",
                                                               gl.ARRAY_BUFFER, minmax=True))
                                for k in range(1, n_t)]
                mesh.weights = [0.0] * (n_t - 1)
                weights = np.zeros((n_t, n_t - 1), dtype=np.float32)
                weights[np.arange(1, n_t), np.arange(n_t - 1)] = 1.0
                out = blob.add(weights.ravel(), "SCALAR")
                anim.samplers.append(gl.AnimationSampler(input=t_acc, output=out, interpolation="LINEAR"))
                anim.channels.append(gl.AnimationChannel(
                    sampler=len(anim.samplers) - 1,
                    target=gl.AnimationChannelTarget(node=len(doc.nodes), path="weights")))
                moving.append(name)
            doc.meshes.append(mesh)
        node.mesh = len(doc.meshes) - 1
        doc.nodes.append(node)
    doc.scenes = [gl.Scene(name=design.name, nodes=list(range(len(doc.nodes))))]
    doc.scene = 0
    if anim.channels:
        doc.animations = [anim]
    doc.buffers = [gl.Buffer(byteLength=len(blob.data))]
    doc.set_binary_blob(bytes(blob.data))
    extra = {"nodes": len(surfaces), "moving_nodes": moving, "keyframes": int(n_t),
             "time_s": [float(times[0]), float(times[-1])], "channels": len(anim.channels)}
    return b"".join(doc.save_to_bytes()), extra
