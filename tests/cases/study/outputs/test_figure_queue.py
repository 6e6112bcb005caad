"""Figures kept and drawn later (cases.study.outputs.figures.canvas.FigureQueue): the same files, byte for byte, as
drawn at once, whether the kept figures are drawn here or side by side on a process pool; nothing is drawn before
``draw_all``; a figure that fails stops the drawing with its error."""
import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import inference
from cases.study.outputs.figures.canvas import FigureQueue, draw, pyplot
from cases.study.outputs.figures.sheet import grid

#: the longest wait for the background drawer, s: it runs at the lowest priority, so on a machine kept busy by other
#: work it draws only when a core falls idle (a wait that ends as soon as the file is there)
PATIENCE = 600


def _panels(n, scale):
    """A sheet of ``n`` panels, each a line of slope ``scale`` * its index."""
    sheet, frames = grid(n, (4.2, 3.2), (0.9, 0.15, 0.6, 0.35), 4)
    x = np.linspace(0.0, 1.0, 50)
    for k, frame in enumerate(frames):
        cell = sheet.cell(*frame, (0.0, 1.0), (0.0, max(scale * k, 1.0)))
        sheet.ax.plot(cell.x(x), cell.y(scale * k * x**2), "C0-")
        cell.x_axis("axial strain eps_a (%)")
        cell.y_axis("q (kPa)")
    return sheet.finish()


def _laid_out(scale):
    """A figure that :func:`save` lays out (plain subplots)."""
    fig, ax = pyplot().subplots(1, 2)
    ax[0].plot([0, 1], [0, scale])
    return fig


def _nothing():
    return None


def _fails():
    raise ValueError("no such curve")


FIGURES = [(_panels, (5, 2.0), "a.png", "SYNTHETIC: five panels", 110), (_laid_out, (3.0,), "b.png", None, 100),
           (_nothing, (), "c.png", "nothing to draw", 110), (_panels, (1, 1.0), "d.png", "one panel", 120)]


def _write(path, text):
    path.write_text(text)


@pytest.mark.parametrize("executor", ["serial", "pool"])
def test_kept_figures_are_the_figures_drawn_at_once(executor, tmp_path):
    now, later = tmp_path / "now", tmp_path / "later"
    now.mkdir()
    later.mkdir()
    queue = FigureQueue()
    for make, args, name, title, dpi in FIGURES:
        draw(make, args, now / name, title, dpi)
        queue(make, args, later / name, title, dpi)
    queue.keep(_write, later / "e.txt", "a file kept with the figures")
    assert not list(later.iterdir())   # kept, not drawn
    with (inference.PoolExecutor(2) if executor == "pool" else inference.SerialExecutor()) as ex:
        queue.draw_all(ex)
    assert sorted(p.name for p in later.iterdir()) == ["a.png", "b.png", "d.png", "e.txt"]
    assert (later / "e.txt").read_text() == "a file kept with the figures"
    for name in ("a.png", "b.png", "d.png"):
        assert (later / name).read_bytes() == (now / name).read_bytes()
    assert queue.jobs == []


def test_a_figure_that_fails_on_the_pool_stops_the_drawing_with_its_error(tmp_path):
    queue = FigureQueue()
    queue(_panels, (2, 1.0), tmp_path / "a.png")
    queue(_fails, (), tmp_path / "b.png")
    with inference.PoolExecutor(2) as ex, pytest.raises(RuntimeError, match="no such curve"):
        queue.draw_all(ex)


@pytest.mark.parametrize("executor", ["serial", "pool"])
def test_a_background_drawer_draws_as_the_figures_are_kept_and_leaves_nothing_behind(executor, tmp_path):
    """The background drawer (start_drawing) draws what it is handed while the queue is filled; draw_all stops it
    and draws the rest: every file as drawn at once, a job that cannot be sent to it (a lambda) drawn at the end, and
    its process gone afterwards."""
    now, later = tmp_path / "now", tmp_path / "later"
    now.mkdir()
    later.mkdir()
    queue = FigureQueue()
    queue.start_drawing()
    process = queue.drawer[0]
    assert process.is_alive()
    for make, args, name, title, dpi in FIGURES:
        draw(make, args, now / name, title, dpi)
        queue(make, args, later / name, title, dpi)
    queue.keep(lambda path: path.write_text("not picklable"), later / "f.txt")
    deadline = time.monotonic() + PATIENCE
    while not (later / "d.png").exists() and time.monotonic() < deadline:   # drawn in the background
        time.sleep(0.05)
    assert (later / "d.png").exists() and not (later / "f.txt").exists()
    with (inference.PoolExecutor(2) if executor == "pool" else inference.SerialExecutor()) as ex:
        queue.draw_all(ex)
    assert sorted(p.name for p in later.iterdir()) == ["a.png", "b.png", "d.png", "f.txt"]
    for name in ("a.png", "b.png", "d.png"):
        assert (later / name).read_bytes() == (now / name).read_bytes()
    assert queue.drawer is None and queue.jobs == [] and not process.is_alive()


def test_a_figure_that_fails_in_the_background_stops_the_drawing_with_its_error(tmp_path):
    queue = FigureQueue()
    queue.start_drawing()
    process = queue.drawer[0]
    queue(_fails, (), tmp_path / "b.png")
    queue.keep(_write, tmp_path / "after.txt", "drawn in order, after the failed one")
    deadline = time.monotonic() + PATIENCE
    while not (tmp_path / "after.txt").exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    assert (tmp_path / "after.txt").exists()   # the drawer went on past the failed figure
    with pytest.raises(RuntimeError, match="(?s)in the background drawer.*no such curve"):
        queue.draw_all(inference.SerialExecutor())
    assert not process.is_alive()


def test_closing_a_queue_stops_its_drawer_and_forgets_the_rest(tmp_path):
    queue = FigureQueue()
    queue.start_drawing()
    process = queue.drawer[0]
    queue.keep(lambda path: path.write_text("never"), tmp_path / "x.txt")   # kept for the end (not picklable)
    queue.close()
    assert queue.drawer is None and queue.jobs == [] and not process.is_alive()
    queue.draw_all(inference.SerialExecutor())   # nothing kept is left to draw
    assert not (tmp_path / "x.txt").exists()



def _busy_then_write(begun, path, seconds):
    """Say it has begun (the file ``begun``), hold this process's interpreter for ``seconds``, then write its process
    id to ``path``."""
    begun.write_text("begun")
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        pass
    path.write_text(str(os.getpid()))


def _write_pid(path, *_):
    path.write_text(str(os.getpid()))


def _read_slowly(seconds):
    time.sleep(seconds)
    return _SlowToRead(0.0)


class _SlowToRead:
    """An argument that takes ``seconds`` to unpickle: the drawer's reading thread is held on it."""

    def __init__(self, seconds):
        self.seconds = seconds

    def __reduce__(self):
        return _read_slowly, (self.seconds,)


def test_the_drawer_stops_after_the_job_in_hand_even_with_jobs_received_behind_it(tmp_path):
    """draw_all stops the background drawer after the job in hand although the drawer has received jobs it has not
    begun and has not yet read the request to stop (its reading thread is held, as a drawer starved of a core is):
    those jobs are drawn by draw_all, here, not one after the other in the drawer before it stops."""
    queue = FigureQueue()
    queue.start_drawing()
    drawer = queue.drawer[0].pid
    queue.keep(_busy_then_write, tmp_path / "begun.txt", tmp_path / "in_hand.txt", 3.0)
    deadline = time.monotonic() + PATIENCE
    while not (tmp_path / "begun.txt").exists() and time.monotonic() < deadline:   # a drawer at the lowest priority
        time.sleep(0.05)
    for k in range(3):
        queue.keep(_write_pid, tmp_path / f"received_{k}.txt")
    queue.keep(_write_pid, tmp_path / "held.txt", _SlowToRead(4.0))   # the reading thread stops here
    time.sleep(0.5)   # the next three received while the first is in hand
    queue.draw_all(inference.SerialExecutor())
    assert (tmp_path / "in_hand.txt").read_text() == str(drawer)
    here = str(os.getpid())
    assert [(tmp_path / f"received_{k}.txt").read_text() for k in range(3)] == [here] * 3
    assert (tmp_path / "held.txt").read_text() == here


def test_an_interpreter_that_ends_with_its_drawer_running_stops_it(tmp_path):
    """A program that ends (an error after the loop started, a test that fails) without draw_all or close: the
    drawer ignores SIGTERM, so multiprocessing's exit handler alone would wait for it forever. The interpreter ends,
    the figure in hand is finished and the drawer is gone."""
    script = tmp_path / "ends.py"
    script.write_text(textwrap.dedent(f"""
        import time
        from pathlib import Path
        from cases.study.outputs.figures.canvas import FigureQueue
        from cases.study.outputs.figures.sheet import grid

        def panels(n):
            sheet, frames = grid(n, (4.2, 3.2), (0.9, 0.15, 0.6, 0.35), 4)
            for k, frame in enumerate(frames):
                cell = sheet.cell(*frame, (0.0, 1.0), (0.0, k + 1.0))
                sheet.ax.plot(cell.x([0.0, 1.0]), cell.y([0.0, k]))
                cell.x_axis("x")
            return sheet.finish()

        def write(path, text):
            path.write_text(text)

        queue = FigureQueue()
        queue.start_drawing()
        print(queue.drawer[0].pid, flush=True)
        queue(panels, (3,), Path({str(tmp_path / "a.png")!r}), "drawn before the end", 110)
        deadline = time.monotonic() + {PATIENCE}
        while not Path({str(tmp_path / "a.png")!r}).exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        queue.keep(write, Path({str(tmp_path / "b.txt")!r}), "kept last")
        time.sleep(0.5)   # the drawer has ignored SIGTERM for a while by now
    """))
    root = Path(__file__).resolve().parents[4]
    done = subprocess.run([sys.executable, str(script)], cwd=root, capture_output=True, text=True, timeout=PATIENCE)
    assert done.returncode == 0, done.stderr
    pid = int(done.stdout.split()[0])
    assert (tmp_path / "a.png").exists()
    deadline = time.monotonic() + 10
    while Path(f"/proc/{pid}").exists() and time.monotonic() < deadline:   # the kernel's bookkeeping of its end
        time.sleep(0.05)
    assert not Path(f"/proc/{pid}").exists()
