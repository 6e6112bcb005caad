"""inference.side_by_side: independent tasks each whole in a forked child, at most `processes` at once; answers in the
tasks' order, errors returned, a child that dies redone here, no process left behind; the cores of ended children
shared among the running ones once none waits (SharedCoresExecutor)."""
import itertools
import os
import signal
import time

import numpy as np
import pytest

from inference import Evaluator, SerialExecutor, side_by_side
from inference.executors.side_by_side import SharedCoresExecutor, can_fork, cores_allotted

pytestmark = pytest.mark.skipif(not can_fork(), reason="side by side needs fork")


def _stamp(k, pause=0.3):
    """A task that says where and when it ran."""
    def task():
        t0 = time.monotonic()
        time.sleep(pause)
        return k, os.getpid(), t0, time.monotonic()
    return task


def test_answers_come_in_the_tasks_order_from_children_at_most_processes_at_once(children_left):
    tasks = [_stamp(k, 0.3 if k != 1 else 0.05) for k in range(5)]
    results = side_by_side(tasks, 2)
    assert [err for _, err in results] == [None] * 5
    values = [v for v, _ in results]
    assert [v[0] for v in values] == list(range(5))
    assert all(v[1] != os.getpid() for v in values) and len({v[1] for v in values}) == 5
    # never more than two running at any instant (every start and end checked against the others' intervals)
    for _, _, t0, t1 in values:
        for moment in (t0 + 1e-4, t1 - 1e-4):
            assert sum(a <= moment <= b for _, _, a, b in values) <= 2
    # and two did run at once (one after the other, no two intervals would overlap; a bound on the whole span would
    # also count the forks of a large parent on a loaded machine)
    assert any(a[2] < b[3] and b[2] < a[3] for a, b in itertools.combinations(values, 2))
    assert not children_left()


def test_an_error_is_the_task_s_answer_and_the_others_still_run():
    def fails():
        raise ValueError("no enrichment for 'offset'")

    results = side_by_side([_stamp(0, 0.01), fails, _stamp(2, 0.01)], 2)
    (v0, e0), (v1, e1), (v2, e2) = results
    assert v0[0] == 0 and v2[0] == 2 and e0 is None and e2 is None
    assert v1 is None and isinstance(e1, ValueError) and str(e1) == "no enrichment for 'offset'"


def test_in_child_runs_the_task_there_and_back_takes_its_answer_here():
    here = os.getpid()
    seen = []

    def in_child(task):
        return "child", os.getpid(), task()

    def back(answer):
        seen.append(os.getpid())
        where, pid, value = answer
        assert where == "child" and pid != here
        return value

    results = side_by_side([lambda: 1, lambda: 2, lambda: 3], 3, in_child, back)
    assert [v for v, _ in results] == [1, 2, 3] and seen == [here] * 3


def test_one_process_or_one_task_runs_here_without_the_hooks():
    def in_child(task):
        raise AssertionError("no child")

    for processes, n in ((1, 3), (4, 1)):
        results = side_by_side([_stamp(k, 0.0) for k in range(n)], processes, in_child, in_child)
        assert [v[1] for v, _ in results] == [os.getpid()] * n


def test_a_child_that_dies_is_redone_here_and_said_once(children_left):
    parent = os.getpid()

    def dies_in_a_child():
        if os.getpid() != parent:
            os.kill(os.getpid(), signal.SIGKILL)
        return "done here"

    lines = []
    results = side_by_side([_stamp(0, 0.01), dies_in_a_child], 2, note=lines.append)
    assert results[1] == ("done here", None) and results[0][0][0] == 0
    assert len(lines) == 1 and "task 2 of 2" in lines[0] and "killed by signal 9" in lines[0]
    side_by_side([_stamp(0, 0.01), dies_in_a_child], 2, note=lines.append, names=["first", "the class of viscosity"])
    assert lines[1].startswith("the class of viscosity: its process") and "main process" in lines[1]
    assert not children_left()


def test_an_error_here_while_children_run_kills_them_first(children_left):
    def back(answer):
        if answer[0] == 0:
            raise RuntimeError("stopped here")
        return answer

    t0 = time.monotonic()
    with pytest.raises(RuntimeError, match="stopped here"):
        side_by_side([_stamp(0, 0.01), _stamp(1, 60.0)], 2, back=back)
    assert time.monotonic() - t0 < 20.0
    assert not children_left()


def _until_allotted(cores, limit_s=30.0):
    """A task that waits until this child may use ``cores`` cores; returns the cores it was allotted at its start and
    the most it saw."""
    def task():
        first = most = cores_allotted()
        deadline = time.monotonic() + limit_s
        while most < cores and time.monotonic() < deadline:
            time.sleep(0.01)
            most = max(most, cores_allotted())
        return first, most
    return task


def test_the_cores_of_ended_children_go_to_those_still_running(children_left):
    assert cores_allotted() == 1   # not in a side-by-side child
    # three tasks on two processes: one core each while the third waits; when the third has started and the
    # quick ones have ended, the one left running is allotted both cores
    def quick():
        return cores_allotted(), cores_allotted()

    results = side_by_side([quick, _until_allotted(2), quick], 2)
    assert [err for _, err in results] == [None] * 3
    assert results[0][0] == (1, 1)          # started while a task waited
    assert results[1][0] == (1, 2)          # one core, then both once the others had ended
    assert results[2][0][0] == 1            # started beside the long one
    assert not children_left()


def _weighted_sum(theta):
    return float(theta @ np.arange(1.0, 1.0 + theta.size))


def test_a_child_allotted_two_cores_evaluates_on_a_pool_of_two_with_the_serial_values(children_left):
    thetas = np.random.default_rng(3).normal(size=(40, 3))
    serial = SerialExecutor().evaluate(Evaluator(_weighted_sum), thetas)[0]

    def evaluate_when_alone():
        _until_allotted(2)()
        with SharedCoresExecutor() as executor:
            values, _, ranks = executor.evaluate(Evaluator(_weighted_sum), thetas)
            return values, sorted(set(ranks.tolist())), cores_allotted()

    results = side_by_side([lambda: None, evaluate_when_alone], 2)
    values, ranks, cores = results[1][0]
    assert cores == 2 and ranks == [0, 1]   # both workers of the child's pool took a share
    np.testing.assert_array_equal(values, serial)
    # where it is not allotted more than one core it evaluates here, as SerialExecutor does
    with SharedCoresExecutor() as executor:
        values, _, ranks = executor.evaluate(Evaluator(_weighted_sum), thetas)
    np.testing.assert_array_equal(values, serial)
    assert not ranks.any()
    assert not children_left()
