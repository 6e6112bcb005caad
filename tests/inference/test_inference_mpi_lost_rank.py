"""A lost MPI rank cannot be replaced: where MPI reports the loss to rank 0, the job ends with one line saying to
rerun with --resume, and status 75. Tested with a stand-in communicator (no rank is killed)."""
import importlib.util
import os
import subprocess
import sys
import textwrap

import pytest

from inference.executors.mpi import EXIT_RANK_LOST, MPIExecutor, RankLost, rank_lost_message

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


class _Comm:
    """Rank 0 of two; Abort is recorded (a real one ends the job)."""

    aborted = None

    def Get_rank(self):
        return 0

    def Get_size(self):
        return 2

    def Abort(self, code):
        self.aborted = code


def test_the_line_says_what_mpi_said_and_to_resume():
    line = rank_lost_message("Other MPI error,\n  error stack: process 1 failed")
    assert line == ("error: an MPI rank was lost (Other MPI error, error stack: process 1 failed); a rank cannot be "
                    "replaced under mpirun: rerun the same command with --resume (resume=True in Python) to continue "
                    "from the last checkpoint")


def test_a_lost_rank_prints_one_line_and_aborts_the_job(capsys):
    comm = _Comm()

    def main():
        raise RankLost("Other MPI error")

    with pytest.raises(RankLost):
        MPIExecutor(comm).run(None, main)
    assert comm.aborted == EXIT_RANK_LOST == 75
    assert capsys.readouterr().err.splitlines() == [rank_lost_message("Other MPI error")]


# rank 0's dynamic dispatch sends to rank 1, which the MPI library reports as gone (an MPI.Exception)
LOST_DURING_A_BATCH = textwrap.dedent("""
    import os, sys
    sys.path.insert(0, {root!r})
    import numpy as np
    from mpi4py import MPI
    from inference.executors import Evaluator, MPIExecutor

    class Comm:
        def Get_rank(self):
            return 0

        def Get_size(self):
            return 2

        def send(self, *args, **kwargs):
            raise MPI.Exception(MPI.ERR_OTHER)

        def Abort(self, code):
            os._exit(code)

    ev = Evaluator(lambda theta: 0.0)
    ex = MPIExecutor(Comm())
    ex.run(ev, lambda: ex.evaluate(ev, np.zeros((4, 1))))
""")


@pytest.mark.skipif(importlib.util.find_spec("mpi4py") is None, reason="mpi4py")
def test_an_mpi_error_during_a_batch_ends_the_job_with_the_line():
    proc = subprocess.run([sys.executable, "-c", LOST_DURING_A_BATCH.format(root=ROOT)], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == EXIT_RANK_LOST, proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: an MPI rank was lost (Other MPI error")
    assert lines[0].endswith("rerun the same command with --resume (resume=True in Python) to continue from the last "
                             "checkpoint")
