"""What an :class:`~foldprint.apps.pipeline.Evaluation` hands the writers: the fold at the
animation's time step and its placed surfaces (xdmf, glb), each hinge's fold time (the
manifest), a state placed by the kinematics (inp), the worst Monte-Carlo sample folded
again, the voxel part; and ``export``, which writes the part's files from them. Each is a
stage of the evaluation (computed on first use, kept: ``Evaluation._stage``).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Iterable

from ..checks.rules import Printer
from ..geometry import build_cost
from ..core.constants import ANIMATION_DT_S
from ..core.errors import ExportError, GeometryError
from ..core.modes import HingeModel, State, parse
from ..geometry import Assembly, build_assembly, state_angles
from ..model.printers import find_printer, tool_fit
from ..physics.kinematics import forward, hinge_frames
from ..physics.recovery.curve import hinge_fold_times
from ..simulation.simulate import SimulationResult, simulate
from .replay import Replay, replay_sample, worst_sample
from .voxel_part import voxel_part, voxel_pitch

if TYPE_CHECKING:  # the writers load when a stage needs them: check and robust write no files
    from ..exchange.fem import PlacedState
    from ..exchange.voxel_regions import Pitch, VoxelPart
    from ..geometry.surfaces import Frames


class ExportStages:
    """The writers' stages of an evaluation and its ``export`` (a mixin of
    :class:`~foldprint.apps.pipeline.Evaluation`, whose ``_stage`` keeps them)."""

    @property
    def animation(self) -> SimulationResult:
        """The fold at the time step of the files that show it over time (xdmf, glb):
        arc hinges, the default collision method and bath."""
        return self._stage("animation", lambda: simulate(self.design, dt=ANIMATION_DT_S, library=self.library,
                                                         mechanics=self.options.mechanics))

    @property
    def frames(self) -> Frames:
        """The fold's surfaces placed at every step of :attr:`animation`: what the xdmf
        and glb writers draw (:func:`foldprint.geometry.surfaces.fold_frames`)."""
        from ..geometry.surfaces import fold_frames

        return self._stage("frames", lambda: fold_frames(self.design, self.animation.trajectory,
                                                         self.animation.compliant))

    @property
    def fold_times(self) -> dict[str, float | None]:
        """Each hinge's 98 % recovery time in the design's bath (s, by hinge id; None where
        it does not fold): what the export's manifest reports."""
        return self._stage("fold_times", lambda: hinge_fold_times(self.design, self.library))

    def placed_state(self, state: State | str) -> PlacedState:
        """``state`` placed by the kinematics (arc hinges): its angles, hinge frames and panel
        poses, what the inp writer meshes (refused first when the design is not a strip)."""
        from ..exchange.fem import PlacedState, check_strip

        st = parse(State, state, "state")

        def run():
            check_strip(self.design)
            angles = state_angles(self.design, st.value)
            frames = tuple(hinge_frames(self.design))
            poses = forward(self.design, angles[None], HingeModel.ARC.value, list(frames))[0]
            return PlacedState(st.value, angles, frames, poses)

        return self._stage(("placed_state", st), run)

    @property
    def worst_replay(self) -> "Replay | None":
        """The worst Monte-Carlo sample (:func:`worst_sample`) folded again, None without samples."""
        def run():
            r = self.robust
            k = None if r is None else worst_sample(r)
            if k is None:
                return None
            return replay_sample(self.design, r, k, library=self.library, dt=self.options.dt,
                                 after_contact=self.options.after_contact)

        return self._stage("worst_replay", run)

    def export(self, out_dir: str | Path, state: State | str | None = None, formats: Iterable[str] | None = None,
               assembly: Assembly | None = None, printer: str | Printer | None = None, force: bool = False) -> list[dict]:
        """Write ``formats`` of the part in ``state`` (default: ``options``) into
        ``out_dir``; the records of :func:`foldprint.exchange.export.export_assembly`
        (``force``: into a folder of other files, beside them).
        The part is ``assembly`` when given, else the evaluation's printed part when it was
        already built (permanent state), else built here (after the size guard). The fold
        is simulated only when a format shows it over time (xdmf, glb). ``printer`` (a
        profile or its key): the printer the files are for: ExportError when the design
        needs more materials than it has tools (:func:`~foldprint.model.printers.tool_fit`);
        the slicer 3MFs describe it when it is an FDM printer; the voxel stack
        (``voxels``) is rasterised at its pitch (default: the J750). The recipe gets the
        check's findings when this evaluation has computed them."""
        from ..exchange.export import TRAJECTORY_FORMATS, check_formats, export_assembly
        from ..exchange.recipe import check_summary

        st = parse(State, self.options.state if state is None else state, "state")
        fmts = check_formats(self.options.formats if formats is None else formats)  # before the (slower) build
        profile = find_printer(printer) if isinstance(printer, str) else printer
        fit = None if profile is None else tool_fit(profile, self.design.materials_used, self.library)
        if fit is not None and not fit.ok:
            raise ExportError(fit.refusal(self.design.source or self.design.name))
        pitch = voxel_pitch(profile) if "voxels" in fmts else None
        if assembly is None and st == State.PERMANENT and self.has("assembly"):
            assembly = self.assembly
            if assembly is None:
                raise GeometryError(self.assembly_error)
        if assembly is None:
            build_cost.check_export(self.design)  # time and memory of the build, estimated from the design
        frames = self.frames if any(f in TRAJECTORY_FORMATS for f in fmts) else None
        check = check_summary(self.printer.name, self.findings) if self.has("findings") else None
        with self.cache.active():
            if assembly is None:
                assembly = build_assembly(self.design, st.value, self.library,
                                          resolution_mm=getattr(profile, "layer_mm", None))
            placed = self.placed_state(st) if "inp" in fmts else None
            voxels = None if pitch is None else self._voxels(assembly, pitch)
            self.build_notes = tuple(assembly.notes)
            return export_assembly(self.design, assembly, out_dir, fmts, self.library, frames, self.fold_times,
                                   placed, voxels, profile, check, force=force)

    def _voxels(self, assembly: Assembly, pitch: Pitch) -> VoxelPart:
        """The part's voxel regions at ``pitch``, after the voxel grid's guard."""
        from ..exchange import voxel_cost

        d = self.design
        voxels = voxel_part(d, assembly, self.library, pitch)
        voxel_cost.check_part(voxels, f"{d.source}: " if d.source else f"{d.name}: ")
        return voxels
