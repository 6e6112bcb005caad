"""Independent tasks side by side, each whole in a child process forked from this one.

What it is for: model classes whose calibrations do not depend on each other (the diagnosis loop's candidates of one
step). Run one after the other on a pool, each class's sampler waits at every sweep for its slowest chunk and
splits its particles into chunks half as large; run side by side, each class keeps one core busy with whole
chunks. When no task is left to start, the cores of the children that have ended are shared among those still
running (:class:`SharedCoresExecutor`: a child's evaluations move to a pool of its share of the cores), so the last
class does not run on one core while the others idle. A task's result does not depend on where it runs (every
evaluation of a parameter set gives the same bits in any batch, ``inference.executors``), so side by side gives what
one after the other gives.
"""
from __future__ import annotations

import multiprocessing as mp
import os
import signal
import sys
import threading
import traceback
from collections import deque
from multiprocessing.connection import wait

from .local import Executor, PoolExecutor, SerialExecutor, child_start, how_it_ended

__all__ = ["side_by_side", "can_fork", "SharedCoresExecutor", "cores_allotted"]

#: in a side-by-side child: the shared cell holding how many cores each running child may use (set by the parent)
_ALLOTMENT = None


def cores_allotted() -> int:
    """The cores this process may evaluate on: in a side-by-side child its share of the cores (1 while tasks wait to
    start; the ended children's cores shared among the running ones once none waits), elsewhere 1."""
    return max(1, int(_ALLOTMENT.value)) if _ALLOTMENT is not None else 1


class SharedCoresExecutor(Executor):
    """Evaluates in this process (``SerialExecutor``), or, in a side-by-side child allotted more than one core
    (:func:`cores_allotted`, read at every batch), on a pool of that many workers forked from this process and kept
    until the allotment changes or :meth:`close`. The values do not depend on which (every evaluation gives the same
    bits in any batch)."""

    name = "shared cores"

    def __init__(self):
        self._serial = SerialExecutor()
        self._pool = None

    def evaluate(self, evaluator, thetas, callback=None, stop=None, note=None):
        cores = cores_allotted()
        if cores < 2 or len(thetas) < 2:
            return self._serial.evaluate(evaluator, thetas, callback, stop, note)
        if self._pool is None or self._pool.processes != cores:
            self.close()
            self._pool = PoolExecutor(cores)
        return self._pool.evaluate(evaluator, thetas, callback, stop, note)

    def close(self):
        if self._pool is not None:
            self._pool.close()
            self._pool = None


def can_fork() -> bool:
    """Whether this platform forks child processes (Linux, and macOS where Python still offers it)."""
    return "fork" in mp.get_all_start_methods()


def _child(task, in_child, conn, owner_pid, death_signal, allotment):
    """A child's whole life: signals and death with its owner (``local.child_start``), its share of the cores
    (``allotment``, :func:`cores_allotted`), the task (through ``in_child``), one answer (value, None) or (None,
    exception) on ``conn``."""
    global _ALLOTMENT
    child_start(owner_pid, death_signal)
    _ALLOTMENT = allotment
    try:
        answer = (in_child(task) if in_child is not None else task(), None)
    except Exception as err:  # noqa: BLE001 - the parent decides what the task's error means
        answer = (None, err)
    try:
        conn.send(answer)
    except Exception:  # noqa: BLE001 - a value or an error that does not pickle
        conn.send((None, RuntimeError(f"a side-by-side task's answer could not be sent back:\n"
                                      f"{traceback.format_exc()}")))
    sys.stdout.flush()
    sys.stderr.flush()


def _here(task) -> tuple:
    try:
        return task(), None
    except Exception as err:  # noqa: BLE001 - returned as a child's would be
        return None, err


def side_by_side(tasks, processes: int, in_child=None, back=None, note=None, names=None) -> list:
    """Run the zero-argument callables ``tasks``, at most ``processes`` at once, each in a child process forked from
    this one (it starts with everything in memory); returns [(value, error)] in the tasks' order: the task's value
    and None, or None and the exception it raised.

    in_child: ``in_child(task)`` runs the task in a child instead of ``task()`` (what the child must change first,
    e.g. its evaluations kept in the child, and what it sends back with the value, e.g. files kept to be written
    later); back: ``back(answer)`` turns a child's answer into the task's value here (what the child sent back is
    taken in). A task that runs here gets neither.

    The tasks start in their order; the children start with this process's output flushed and flush their own.
    A child that dies without answering (killed, out of memory, a crash in compiled code) has its task run again
    here once the others are done, and says so in one line (``note(line)``, else stderr; the task named by
    ``names``, else by its number). A child's evaluations may use its share of the cores through
    :class:`SharedCoresExecutor`. Where fork is not available, with one process or with one task, the tasks run here
    one after the other. Children ignore SIGTERM/SIGINT and die with this process (``local.child_start``); should
    this process stop while it waits (an exception, Ctrl-C), the children are killed and waited for before it goes
    on.
    """
    tasks = list(tasks)
    if processes < 2 or len(tasks) < 2 or not can_fork():
        return [_here(task) for task in tasks]
    ctx = mp.get_context("fork")
    results, pending, running, again = [None] * len(tasks), deque(range(len(tasks))), {}, []
    death_signal = threading.current_thread() is threading.main_thread()
    allotment = ctx.RawValue("i", 1)   # the cores of each running child (module docstring)
    try:
        while pending or running:
            while pending and len(running) < processes:
                k = pending.popleft()
                sys.stdout.flush()
                sys.stderr.flush()
                mine, theirs = ctx.Pipe(duplex=False)
                child = ctx.Process(target=_child, args=(tasks[k], in_child, theirs, os.getpid(), death_signal,
                                                         allotment), name="side-by-side")
                child.start()
                theirs.close()
                running[mine] = (k, child)
            allotment.value = 1 if pending or not running else processes // len(running)
            for conn in wait(list(running)):
                k, child = running.pop(conn)
                try:
                    answer = conn.recv()
                except (EOFError, OSError):   # it died before answering
                    answer = None
                conn.close()
                child.join()
                if answer is None:
                    what = names[k] if names else f"side-by-side task {k + 1} of {len(tasks)}"
                    line = (f"{what}: its process {child.pid} {how_it_ended(child.exitcode)} without answering; "
                            "run again in the main process")
                    if note is None:
                        print(line, file=sys.stderr, flush=True)
                    else:
                        note(line)
                    again.append(k)
                    continue
                value, error = answer
                results[k] = (back(value) if back is not None and error is None else value, error)
    except BaseException:
        for _, child in running.values():
            if child.is_alive():
                os.kill(child.pid, signal.SIGKILL)
            child.join()
        raise
    for k in again:
        results[k] = _here(tasks[k])
    return results
