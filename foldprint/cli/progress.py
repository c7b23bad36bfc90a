"""The command line's progress displays on stderr: a bar of Monte-Carlo samples, one bar
per stage of check's sequential tests, a spinner; none when stderr is not a terminal,
with --quiet or --json.
"""

from __future__ import annotations

import sys

from .printing import OUTPUT_STATE


def _progress_off(silent: bool) -> bool:
    """No progress display: --quiet, --json (``silent``), or stderr not a terminal."""
    return silent or OUTPUT_STATE["quiet"] or not sys.stderr.isatty()


def _bar(at_most: bool):
    """A rich progress display on stderr: what, a bar, done/total, the rate, the time left
    (``at_most``: an upper bound, the total being a maximum a sequential test may not
    need) or a note ("decided"), the time elapsed."""
    from rich.console import Console
    from rich.progress import BarColumn, Progress, ProgressColumn, SpinnerColumn, TextColumn, TimeElapsedColumn
    from rich.text import Text

    class Count(ProgressColumn):
        def render(self, task):
            return Text("" if task.total is None else f"{int(task.completed)}/{int(task.total)}",
                        style="progress.download")

    class Rate(ProgressColumn):
        def render(self, task):
            return Text(f"{task.speed:.1f}/s" if task.speed else "", style="progress.data.speed")

    class Left(ProgressColumn):
        def render(self, task):
            note = task.fields.get("note", "")
            if note or task.total is None or not task.speed:
                return Text(note, style="progress.remaining")
            secs = int(round((task.total - task.completed) / task.speed))
            left = f"{secs // 60}:{secs % 60:02d} left"
            return Text(f"at most {left}" if at_most else left, style="progress.remaining")

    return Progress(SpinnerColumn(), TextColumn("{task.description}"), BarColumn(bar_width=16), Count(), Rate(),
                    Left(), TimeElapsedColumn(), transient=True, console=Console(stderr=True))


def samples_progress(label: str, silent: bool = False):
    """A context manager giving a ``progress(done, total)`` callback: a bar on stderr with
    the rate and time left, when stderr is a terminal and not --quiet or ``silent``
    (--json); else None."""
    import contextlib

    if _progress_off(silent):
        return contextlib.nullcontext(None)

    @contextlib.contextmanager
    def bar():
        with _bar(False) as p:
            task = p.add_task(label, total=None)
            yield lambda done, total: p.update(task, completed=done, total=total)

    return bar()


def stage_progress(title: str, silent: bool = False):
    """A context manager giving ``progress(stage, done, total)`` for an evaluation whose
    stages are sequential tests: a line saying what runs from the first second, then one
    bar per stage with its samples so far of the maximum, the rate and the time left at
    most, and "decided" once the stage reports (n, n) below its maximum. None when
    stderr is not a terminal, with --quiet or ``silent`` (--json)."""
    import contextlib

    if _progress_off(silent):
        return contextlib.nullcontext(None)

    @contextlib.contextmanager
    def bars():
        with _bar(True) as p:
            p.add_task(title, total=None)
            tasks: dict = {}

            def update(stage: str, done: int, total: int) -> None:
                if stage not in tasks:
                    tasks[stage] = (p.add_task(f"  {stage}", total=total), total)
                task, most = tasks[stage]
                note = "" if done < total else ("decided" if total < most else "done")
                p.update(task, completed=done, total=most, note=note)

            yield update

    return bars()


def with_progress(label: str, fn):
    """Run ``fn`` with a spinner on stderr when stderr is a terminal and not --quiet."""
    if OUTPUT_STATE["quiet"] or not sys.stderr.isatty():
        return fn()
    from rich.console import Console

    with Console(stderr=True).status(label):
        return fn()
