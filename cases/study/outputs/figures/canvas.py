"""Where the figures are drawn: pyplot on the off-screen Agg backend, the settings shared by the figures' panels (at
most ``MAX_COLUMNS`` side by side, so that many curves make more rows, not a row of thousands of pixels; the panels
themselves are cells of a :mod:`cases.study.outputs.figures.sheet`), and figures drawn now (:func:`draw`) or kept and
drawn later side by side on a process pool (:class:`FigureQueue`)."""
from __future__ import annotations

import os
import threading
import time

import numpy as np

from inference import PoolExecutor
from inference.executors.local import child_start, close_at_exit, closed

__all__ = ["FIXED", "MAX_COLUMNS", "PANEL_MARGINS", "PANEL_TICKS", "TITLE_ROOM", "FigureQueue",
           "draw", "logarithmic_time", "pyplot", "save"]

#: the most panels side by side
MAX_COLUMNS = 4
#: the most intervals between the ticks of a panel's linear axis (matplotlib's ``nbins``)
PANEL_TICKS = 5


def pyplot():
    """matplotlib.pyplot on the off-screen Agg backend."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


#: the room around a panel of curves (inches): tick and axis labels on the left and at the bottom, the panel's title
#: at the top
PANEL_MARGINS = {"left": 0.9, "right": 0.15, "bottom": 0.6, "top": 0.35}
#: the room for a figure's title above the grid (inches)
TITLE_ROOM = 0.4
#: the mark of a figure whose panels are placed on a fixed grid already (:func:`save` lays out the others)
FIXED = "fixed grid"


def logarithmic_time(x_name: str, x) -> bool:
    """Whether an abscissa is drawn on a log scale: a time (``x_name`` "time" or "stage_time", values ``x`` in s)
    spanning more than two decades (creep, relaxation and consolidation records are logged at growing intervals);
    any other abscissa is linear."""
    x = np.asarray(x, float)
    return x_name in ("time", "stage_time") and x.min() > 0 and x.max() > 100 * x.min()


def save(fig, path, title: str | None = None, dpi: int = 110):
    """Title ``fig``, lay it out (matplotlib's tight layout, unless its panels are placed on a fixed grid already:
    a figure labelled ``FIXED``), write it to ``path`` and close it."""
    plt = pyplot()
    if title:
        fig.suptitle(title, fontsize=10, y=1 - 0.08 / fig.get_figheight(), va="top")
    if fig.get_label() != FIXED:
        fig.tight_layout(rect=(0, 0, 1, 1 - 0.45 / fig.get_figheight()) if title else None)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


def draw(make, args, path, title: str | None = None, dpi: int = 110):
    """Draw the figure ``make(*args)`` now and :func:`save` it to ``path`` under ``title`` (nothing when ``make``
    returns None)."""
    fig = make(*args)
    if fig is not None:
        save(fig, path, title, dpi)


class _Drawing:
    """The kept figures as an evaluator of the executors' protocol: each row of ``rows`` is the index of one figure,
    drawn by the worker that gets it (values 0, no failure reasons)."""

    vectorized = False
    loglike = None

    def __init__(self, jobs: list):
        self.jobs = jobs

    def __call__(self, rows):
        for row in rows:
            write, args = self.jobs[int(row[0])]
            write(*args)
        return np.zeros(len(rows)), [None] * len(rows)


def _background_drawer(jobs_in, done_out, stop_now, parents_ends, owner_pid, death_signal):
    """The background drawer's process (:meth:`FigureQueue.start_drawing`): at the lowest priority, draw or write
    each job (index, writer, args) received on ``jobs_in`` in the order kept, answering ("done", index) or ("failed",
    index, traceback) on ``done_out``; when the event ``stop_now`` is set, on None, or when the parent's end of the
    pipe closes, stop after the job in hand (the jobs received and not begun are left to the parent) and answer
    ("stopped",). A thread receives the jobs as they come, so the parent never waits on a send.
    ``parents_ends``: the parent's ends of the two pipes, closed here; ``owner_pid``, ``death_signal``: of
    ``inference.executors.local.child_start`` (signals left to the parent, death with it), as a pool worker."""
    import traceback
    from collections import deque

    for end in parents_ends:
        end.close()
    child_start(owner_pid, death_signal)
    try:   # Linux: run only on a core nothing else wants
        os.sched_setscheduler(0, os.SCHED_IDLE, os.sched_param(0))
    except (AttributeError, OSError):   # no such policy here, or a sandbox refuses it
        if hasattr(os, "nice"):
            os.nice(19)
    pending, stop, arrived = deque(), threading.Event(), threading.Condition()

    def receive():
        while True:
            try:
                job = jobs_in.recv()
            except (EOFError, OSError):
                job = None
            except Exception:  # noqa: BLE001 - a job that cannot be read here is drawn at the end
                continue
            with arrived:
                if job is None:
                    stop.set()
                else:
                    pending.append(job)
                arrived.notify()
            if job is None:
                return

    threading.Thread(target=receive, daemon=True).start()
    while True:
        with arrived:
            arrived.wait_for(lambda: pending or stop.is_set())
            if stop.is_set() or stop_now.is_set():
                break
            index, write, args = pending.popleft()
        try:
            write(*args)
        except Exception:   # the parent raises it with the figure's error
            done_out.send(("failed", index, traceback.format_exc()))
        else:
            done_out.send(("done", index))
    try:
        done_out.send(("stopped",))
    except OSError:   # the parent has gone
        pass


class FigureQueue:
    """Figures kept to be drawn later, side by side. Called as :func:`draw` is, it keeps the figure's maker, its
    arguments, path, title and resolution; :meth:`keep` keeps any other file's writer that nothing reads before the
    end (a class's posterior.nc); :meth:`draw_all` draws and writes what was kept on the workers of a local process
    pool (``inference.PoolExecutor``: forked with the figures' data in memory, one figure a task, workers that die
    with their parent), or here, one after the other, on any other executor; a background drawer
    (:meth:`start_drawing`) may draw them before, as they are kept. A figure is the same wherever it is drawn."""

    def __init__(self):
        self.jobs = []
        self.drawer = None   # the background drawer: (process, jobs' pipe, answers' pipe, its stop event)

    def __call__(self, make, args, path, title: str | None = None, dpi: int = 110):
        self.keep(draw, make, args, path, title, dpi)

    def keep(self, write, *args):
        """Keep ``write(*args)`` (a file's writer) to be called with the figures; handed at once to the background
        drawer when one runs (:meth:`start_drawing`) and the job can be sent (pickled)."""
        self.jobs.append((write, args))
        if self.drawer is not None:
            try:
                self.drawer[1].send((len(self.jobs) - 1, write, args))
            except Exception:  # noqa: BLE001 - not picklable, or the drawer has gone: drawn at the end
                pass

    def start_drawing(self):
        """Start the background drawer: a process at the lowest priority (Linux ``SCHED_IDLE``, else nice 19) that
        draws the figures and writes the files as they are kept, on the time the loop leaves a core idle (a sampler
        waiting for its slowest chunk, the parent's own work); :meth:`draw_all` stops it after the job in hand and
        draws what is left. It ends with the pipe from this process (at :meth:`draw_all` or :meth:`close`, at the
        latest when the interpreter ends), and with this process as a pool worker does
        (``inference.executors.local.child_start``)."""
        import multiprocessing as mp

        if "fork" not in mp.get_all_start_methods():   # forked: it starts with pyplot and the modules imported
            return
        pyplot()
        ctx = mp.get_context("fork")
        jobs_in, jobs_out = ctx.Pipe(duplex=False)
        done_in, done_out = ctx.Pipe(duplex=False)
        stop_now = ctx.Event()
        process = ctx.Process(target=_background_drawer, daemon=True,
                              args=(jobs_in, done_out, stop_now, (jobs_out, done_in), os.getpid(),
                                    threading.current_thread() is threading.main_thread()))
        process.start()
        jobs_in.close()
        done_out.close()
        self.drawer = (process, jobs_out, done_in, stop_now)
        # it ignores SIGTERM: an interpreter that ends without draw_all or close stops it; a queue collected before
        # closes the pipe it reads, and it ends
        close_at_exit(self, weak=True)

    def _stop_drawing(self) -> set:
        """Stop the background drawer after the job in hand; the indices of the jobs it drew or wrote. A job that
        failed there raises RuntimeError with its error."""
        process, jobs_out, done_in, stop_now = self.drawer
        self.drawer = None
        done = set()
        stop_now.set()   # the None below is read only after every job sent before it (a starved drawer lags)
        try:
            jobs_out.send(None)
            while True:
                answer = done_in.recv()
                if answer[0] == "stopped":
                    break
                if answer[0] == "failed":
                    raise RuntimeError(f"a kept figure or file failed in the background drawer:\n{answer[2]}")
                done.add(answer[1])
        except (EOFError, OSError):   # it died: whatever it did not say it did is done here
            pass
        finally:
            jobs_out.close()
            done_in.close()
            process.join()
            closed(self)
        return done

    def close(self):
        """Stop the background drawer, if one runs, after the job in hand, and forget what was kept (a loop that
        stopped early: what the drawer finished stays written)."""
        if self.drawer is not None:
            try:
                self._stop_drawing()
            except RuntimeError:   # a figure's error: the loop's own error is the one to see
                pass
        self.jobs = []

    def draw_all(self, executor=None) -> float:
        """Draw the kept figures (on ``executor``'s workers when it is a process pool) and forget them; returns the
        wall time (s). On a pool the last kept is drawn first (a loop keeps its own figures, of every curve, last:
        the largest start first and the small ones fill in, so the workers finish together), with pyplot imported
        before the workers are forked."""
        t0 = time.perf_counter()
        done = self._stop_drawing() if self.drawer is not None else set()
        jobs, self.jobs = [job for k, job in enumerate(self.jobs) if k not in done], []
        if isinstance(executor, PoolExecutor) and len(jobs) > 1:
            pyplot()
            executor.evaluate(_Drawing(jobs), np.arange(len(jobs) - 1, -1, -1, dtype=float)[:, None])
        else:
            for write, args in jobs:
                write(*args)
        return time.perf_counter() - t0
