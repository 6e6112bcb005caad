"""Every bad input is refused clearly, before any solve: a corpus of bad recording CSVs, study files, command lines
and checkpoints given to both entry points (``cases.calibrate STUDY`` and ``cases.burswood_sbp --recordings``). Each
must give exit status 2 and one line on stderr naming the file, field or option and the value, no traceback and
nothing written in --out. Valid variants (CRLF, MPa, quoted numbers, bracket units, byte-order mark) load to the same
values as the plain file. Most cases run in-process through the commands' ``main(argv)``; a handful run as real
subprocesses (a crafted pickle checkpoint that tries to run code among them). The corpus itself is in
tests/corpus_inputs.py."""
import json
import os
import pickle
import re
import shutil
import socket
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest
from corpus_inputs import (
    BURSWOOD_ARGS,
    CALIBRATE_ARGS,
    LAB_CSV,
    LAB_CSVS,
    LAB_TOML,
    LAB_TOMLS,
    LAB_VARIANTS,
    PROGRAMME_CSVS,
    PROGRAMME_TOML,
    SBP_CSV,
    SBP_CSVS,
    SBP_TOMLS,
    SBP_VARIANTS,
    sbp_rows,
)

import inference
from cases import burswood_sbp, calibrate, simsand_synthetic, toyoura
from cases.study import runner
from cases.study.cli import command
from cases.study.loop.study_problem import StudyProblem
from cases.study.reading.records import load_observations, load_sbp_recordings
from cases.study.reading.schema import load_study

ROOT = Path(__file__).resolve().parents[4]
EXAMPLES = ROOT / "cases" / "examples"

# ------------------------------------------------------------------------------------------------ helpers
def _lab(tmp_path, toml=LAB_TOML, csv=LAB_CSV):
    """A lab study folder: study.toml and t1.csv (text or bytes)."""
    (tmp_path / "t1.csv").write_bytes(csv if isinstance(csv, bytes) else csv.encode())
    (tmp_path / "study.toml").write_bytes(toml if isinstance(toml, bytes) else toml.encode())
    return tmp_path / "study.toml"


def _sbp_study(tmp_path, csv=SBP_CSV, edit=lambda t: t):
    """The shipped SBP example study with its record replaced by ``csv``; ``edit`` changes the TOML text."""
    (tmp_path / "data").mkdir(exist_ok=True)
    (tmp_path / "data" / "sbp_fast.csv").write_bytes(csv if isinstance(csv, bytes) else csv.encode())
    text = edit((EXAMPLES / "sbp.toml").read_text())
    (tmp_path / "study.toml").write_text(text)
    return tmp_path / "study.toml"


def _status(main, argv):
    try:
        return main([str(a) for a in argv])
    except SystemExit as exc:
        return exc.code


def refused(main, argv, capsys, out, named, keep=()):
    """Run ``main(argv)`` in-process: exit status 2, one line on stderr holding every part of ``named``, no
    traceback, and nothing in ``out`` but the files ``keep``."""
    capsys.readouterr()
    status = _status(main, argv)
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert status == 2, err
    assert "Traceback" not in err and len(lines) == 1, err
    for part in named:
        assert part in lines[0], lines[0]
    left = sorted(p.name for p in out.iterdir()) if out.exists() else []
    assert left == sorted(keep), left


# ------------------------------------------------------------------------------------------------ bad CSVs, lab
@pytest.mark.parametrize("csv, named", [c[1:] for c in LAB_CSVS], ids=[c[0] for c in LAB_CSVS])
def test_bad_lab_csv_is_refused_by_calibrate(tmp_path, capsys, csv, named):
    out = tmp_path / "out"
    refused(calibrate.main, [_lab(tmp_path, csv=csv), "--quick", "--out", out], capsys, out, ["t1.csv", *named])


def test_a_bad_generating_value_is_refused_by_generate(tmp_path, capsys):
    """--generate with a [synthetic] parameter the model refuses: one line naming the file and synthetic.parameters,
    exit 2, no record written."""
    text = (EXAMPLES / "triaxial_drained.toml").read_text().replace("parameters = { e_ref = 0.75", "parameters = { "
                                                                     "e_ref = -0.75")
    assert "e_ref = -0.75" in text
    study = tmp_path / "study.toml"
    study.write_text(text)
    refused(calibrate.main, [study, "--generate"], capsys, tmp_path / "data",
            [str(study), "synthetic.parameters", "e_ref = -0.75"])


@pytest.mark.parametrize("csv, named", [c[1:] for c in PROGRAMME_CSVS], ids=[c[0] for c in PROGRAMME_CSVS])
def test_bad_programme_csv_is_refused_by_calibrate(tmp_path, capsys, csv, named):
    out = tmp_path / "out"
    refused(calibrate.main, [_lab(tmp_path, toml=PROGRAMME_TOML, csv=csv), "--quick", "--out", out], capsys, out,
            ["t1.csv", *named])


# ------------------------------------------------------------------------------------------------ bad CSVs, SBP
@pytest.mark.parametrize("csv, named", [c[1:] for c in SBP_CSVS], ids=[c[0] for c in SBP_CSVS])
def test_bad_sbp_csv_is_refused_by_burswood_recordings(tmp_path, capsys, csv, named):
    path = tmp_path / "fast.csv"
    path.write_bytes(csv if isinstance(csv, bytes) else csv.encode())
    out = tmp_path / "out"
    refused(burswood_sbp.main, ["--quick", "--processes", "1", "--recordings", f"fast={path}", "--out", out],
            capsys, out, ["fast.csv", *named])


@pytest.mark.parametrize("csv, named", [c[1:] for c in SBP_CSVS], ids=[c[0] for c in SBP_CSVS])
def test_bad_sbp_csv_is_refused_by_a_calibrate_study(tmp_path, capsys, csv, named):
    out = tmp_path / "out"
    refused(calibrate.main, [_sbp_study(tmp_path, csv), "--quick", "--out", out], capsys, out,
            ["sbp_fast.csv", *named])


# ------------------------------------------------------------------------------------------------ bad study files
@pytest.mark.parametrize("edit, named", [c[1:] for c in LAB_TOMLS], ids=[c[0] for c in LAB_TOMLS])
def test_bad_study_file_is_refused(tmp_path, capsys, edit, named):
    out = tmp_path / "out"
    path = _lab(tmp_path, toml=edit(LAB_TOML))
    refused(calibrate.main, [path, "--quick", "--out", out], capsys, out, ["study.toml", *named])


@pytest.mark.parametrize("edit, named", [c[1:] for c in SBP_TOMLS], ids=[c[0] for c in SBP_TOMLS])
def test_bad_sbp_study_file_is_refused(tmp_path, capsys, edit, named):
    out = tmp_path / "out"
    refused(calibrate.main, [_sbp_study(tmp_path, edit=edit), "--quick", "--out", out], capsys, out,
            ["study.toml", *named])


# ------------------------------------------------------------------------------------------------ bad command lines
@pytest.mark.parametrize("extra, named", [c[1:] for c in CALIBRATE_ARGS], ids=[c[0] for c in CALIBRATE_ARGS])
def test_bad_calibrate_command_line_is_refused(tmp_path, capsys, extra, named):
    out = tmp_path / "out"
    refused(calibrate.main, [_lab(tmp_path), "--quick", "--out", out, *extra], capsys, out, named)


def test_calibrate_without_a_study_and_with_a_folder_as_study(tmp_path, capsys):
    out = tmp_path / "out"
    refused(calibrate.main, ["--quick", "--out", out], capsys, out, ["study"])
    refused(calibrate.main, [tmp_path, "--quick", "--out", out], capsys, out, [str(tmp_path), "not a file"])
    refused(calibrate.main, [tmp_path / "none.toml", "--out", out], capsys, out, ["none.toml", "not found"])


@pytest.mark.parametrize("entry", ["calibrate", "burswood"])
@pytest.mark.parametrize("where", ["file", "under a file"])
def test_out_naming_an_existing_file_is_refused(tmp_path, capsys, entry, where):
    existing = tmp_path / "taken"
    existing.write_text("mine")
    out = existing if where == "file" else existing / "run"
    argv = ([_lab(tmp_path), "--quick"] if entry == "calibrate" else ["--quick", "--recordings",
                                                                      f"fast={_sbp_file(tmp_path)}"])
    refused(_MAINS[entry], [*argv, "--out", out], capsys, tmp_path / "no-out", ["--out", "taken"])
    assert existing.read_text() == "mine"


def _sbp_file(tmp_path, text=SBP_CSV):
    path = tmp_path / "fast.csv"
    path.write_text(text)
    return path


_MAINS = {"calibrate": calibrate.main, "burswood": burswood_sbp.main}

@pytest.mark.parametrize("extra, named", [c[1:] for c in BURSWOOD_ARGS], ids=[c[0] for c in BURSWOOD_ARGS])
def test_bad_burswood_command_line_is_refused(tmp_path, capsys, extra, named):
    out = tmp_path / "out"
    f = _sbp_file(tmp_path)
    p = tmp_path / "pressure_only.csv"
    p.write_text(sbp_rows("1,100", "2,120", header="cavity_strain_pct,cavity_pressure_kPa"))
    extra = [a.format(f=f, d=tmp_path, p=p) for a in extra]
    refused(burswood_sbp.main, ["--quick", "--processes", "1", "--out", out, *extra], capsys, out, named)


@pytest.mark.parametrize("main, extra, named", [
    (toyoura.main, ["--undrained", "a.csv:1.0"], ["--undrained", "'a.csv:1.0'"]),
    (toyoura.main, ["--undrained", "none.csv"], ["none.csv", "not found"]),
    (toyoura.main, ["--free", "phi"], ["--free", "phi"]),
    (simsand_synthetic.main, ["--free", "phi_mu,phi"], ["--free", "phi"]),
    (simsand_synthetic.main, ["--noise", "0.3"], ["--noise", "0.3"]),
    (simsand_synthetic.main, ["--seed", "-4"], ["--seed", "'-4'"]),
], ids=["toyoura undrained spec", "toyoura undrained file", "toyoura free", "simsand free", "simsand noise",
        "simsand seed"])
def test_bad_sand_study_command_line_is_refused(tmp_path, capsys, main, extra, named):
    out = tmp_path / "out"
    refused(main, ["--quick", "--processes", "1", "--out", out, *extra], capsys, out, named)


# ------------------------------------------------------------------------------------------------ checkpoints
class _RunsCode:
    """Unpickling this calls os.system: a checkpoint that tries to run code (it must never be unpickled)."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return os.system, (f"touch {self.marker}",)


@pytest.fixture(scope="module")
def genuine(tmp_path_factory):
    """A real checkpoint of the lab study (a quick run stopped after one stage), its run folder and study."""
    d = tmp_path_factory.mktemp("genuine")
    study = load_study(_lab(d))
    observations, times = load_observations(study.tests)
    problem = StudyProblem(study, observations, times, quick=True, processes=1)
    like = inference.Likelihood(observations, problem.forward(study.switches), batch=True)
    prior = problem.prior(study.free, study.log_uniform)
    out = d / "stopped"
    with pytest.raises(inference.RunStopped) as stop:
        runner.calibrate(like, prior, runner.RunSettings(quick=True, processes=1), out, 1, 8, max_steps=4,
                         max_stages=1)
    return d, out, stop.value


def _always_fails(theta):
    raise RuntimeError("no solution")


def test_a_stopped_run_keeps_its_progress_and_says_why(genuine, tmp_path, capsys):
    _, out, stop = genuine
    assert "max_stages" in json.loads((out / "progress.json").read_text())["stopped"] and "max_stages" in str(stop)
    assert (out / "failed_solves.jsonl").exists() and (out / "run.ckpt").exists()
    prior = inference.UniformPrior({"a": (0.0, 1.0), "b": (0.0, 1.0)})
    capsys.readouterr()
    with pytest.raises(inference.RunStopped):
        runner.calibrate(_always_fails, prior, runner.RunSettings(processes=1), tmp_path / "failing", 1, 8,
                         executor=inference.SerialExecutor(), progress=False)
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("the run stopped: ") and "progress.json" in lines[0]
    failed = (tmp_path / "failing" / "failed_solves.jsonl").read_text().splitlines()
    assert len(failed) == 8 and all("no solution" in json.loads(f)["reason"] for f in failed)
    assert json.loads((tmp_path / "failing" / "progress.json").read_text())["n_failed_solves"] == 8


def _flip(data: bytes, start: int, n: int = 64) -> bytes:
    return data[:start] + bytes(b ^ 0xFF for b in data[start:start + n]) + data[start + n:]


def _zip(path, members):
    with zipfile.ZipFile(path, "w") as zf:
        for name, data in members.items():
            zf.writestr(name, data)


def _checkpoints(genuine_ckpt, marker):
    real = genuine_ckpt.read_bytes()
    return {
        "pickle that runs code": lambda p: p.write_bytes(pickle.dumps(_RunsCode(marker))),
        "pickle of a list": lambda p: p.write_bytes(pickle.dumps([1, 2, 3])),
        "pickle of a dict": lambda p: p.write_bytes(pickle.dumps({"state": None})),
        "random bytes": lambda p: p.write_bytes(np.random.default_rng(0).bytes(4096)),
        "empty file": lambda p: p.write_bytes(b""),
        "text file": lambda p: p.write_text("resume me\n"),
        "truncated": lambda p: p.write_bytes(real[: len(real) // 2]),
        "64 bytes inverted": lambda p: p.write_bytes(_flip(real, len(real) // 3)),
        "64 bytes inverted at the end": lambda p: p.write_bytes(_flip(real, len(real) - 200)),
        "zip without meta": lambda p: _zip(p, {"a0.npy": b"x"}),
        "npz of pickled objects": lambda p: np.savez(p.with_suffix(".npz"), a=np.array([{"x": 1}], dtype=object))
        or p.with_suffix(".npz").rename(p),
        "a folder": lambda p: p.mkdir(),
    }


CHECKPOINT_CASES = ["pickle that runs code", "pickle of a list", "pickle of a dict", "random bytes", "empty file",
                    "text file", "truncated", "64 bytes inverted", "64 bytes inverted at the end", "zip without meta",
                    "npz of pickled objects", "a folder"]


@pytest.mark.parametrize("case", CHECKPOINT_CASES)
def test_bad_checkpoint_is_refused_and_never_run(tmp_path, capsys, genuine, case):
    marker = tmp_path / "MARKER"
    out = tmp_path / "out"
    out.mkdir()
    _checkpoints(genuine[1] / "run.ckpt", marker)[case](out / "run.ckpt")
    refused(calibrate.main, [_lab(tmp_path), "--quick", "--processes", "1", "--out", out, "--resume"], capsys, out,
            ["run.ckpt"], keep=["run.ckpt"])
    assert not marker.exists()


@pytest.mark.parametrize("extra, named", [
    (["--seed", "2"], ["seed"]),
    (["--samples", "16"], ["n_samples"]),
    (["--method", "o"], ["proposal"]),
], ids=["other seed", "other samples", "other method"])
def test_checkpoint_of_other_settings_names_what_differs(tmp_path, capsys, genuine, extra, named):
    d, stopped, _ = genuine
    out = tmp_path / "out"
    out.mkdir()
    shutil.copy(stopped / "run.ckpt", out / "run.ckpt")
    argv = [d / "study.toml", "--quick", "--processes", "1", "--samples", "8", "--seed", "1", "--out", out, "--resume"]
    refused(calibrate.main, argv + extra, capsys, out, ["run.ckpt", "refusing to resume", *named], keep=["run.ckpt"])


def test_checkpoint_of_other_data_is_refused(tmp_path, capsys, genuine):
    """The same study file with one recorded value changed: the checkpoint's data fingerprint differs."""
    out = tmp_path / "out"
    out.mkdir()
    shutil.copy(genuine[1] / "run.ckpt", out / "run.ckpt")
    path = _lab(tmp_path, csv=LAB_CSV.replace("1.0,70", "1.0,71"))
    refused(calibrate.main, [path, "--quick", "--processes", "1", "--samples", "8", "--out", out, "--resume"], capsys,
            out, ["run.ckpt", "refusing to resume"], keep=["run.ckpt"])


@pytest.mark.parametrize("case", ["pickle that runs code", "64 bytes inverted", "zip without meta"])
def test_bad_checkpoint_is_refused_by_burswood(tmp_path, capsys, genuine, case):
    marker = tmp_path / "MARKER"
    out = tmp_path / "out"
    out.mkdir()
    _checkpoints(genuine[1] / "run.ckpt", marker)[case](out / "run.ckpt")
    refused(burswood_sbp.main, ["--quick", "--processes", "1", "--recordings", f"fast={_sbp_file(tmp_path)}",
                                "--out", out, "--resume"], capsys, out, ["run.ckpt"], keep=["run.ckpt"])
    assert not marker.exists()


# ------------------------------------------------------------------------------------------------ the lock on --out
def _lock(out, pid, host=None):
    out.mkdir(parents=True, exist_ok=True)
    (out / runner.LOCK_FILE).write_text(json.dumps({"pid": pid, "host": host or socket.gethostname(),
                                                     "started": "2026-01-01T00:00:00+00:00"}))


def test_a_second_run_on_the_same_out_is_refused_naming_the_first(tmp_path, capsys):
    sleeper = subprocess.Popen(["sleep", "60"])
    try:
        out = tmp_path / "out"
        _lock(out, sleeper.pid)
        refused(calibrate.main, [_lab(tmp_path), "--quick", "--processes", "1", "--out", out], capsys, out,
                [str(out), "in use by another run", f"pid {sleeper.pid}", socket.gethostname(), "2026-01-01"],
                keep=[runner.LOCK_FILE])
        _lock(tmp_path / "other", 1, host="elsewhere")  # another host: its pid cannot be checked, the lock holds
        with pytest.raises(runner.OutputLocked, match="pid 1 on host elsewhere"):
            with runner.out_lock(tmp_path / "other"):
                pass
    finally:
        sleeper.kill()
        sleeper.wait()


def test_a_stale_lock_is_taken_over_with_a_note_and_released(tmp_path, capsys):
    dead = subprocess.Popen(["true"])
    dead.wait()
    out = tmp_path / "out"
    _lock(out, dead.pid)
    with runner.out_lock(out):
        assert json.loads((out / runner.LOCK_FILE).read_text())["pid"] == os.getpid()
        with pytest.raises(runner.OutputLocked, match=f"pid {os.getpid()}"):
            with runner.out_lock(out):
                pass
    assert "taking over the stale lock" in capsys.readouterr().err
    assert sorted(out.iterdir()) == []  # released; the folder existed before, it stays
    with runner.out_lock(tmp_path / "new"):
        assert (tmp_path / "new" / runner.LOCK_FILE).exists()
    assert not (tmp_path / "new").exists()  # made by the lock and left empty: removed


@pytest.mark.parametrize("error, status, words", [
    (RuntimeError("solver state lost"), 2, ["unexpected RuntimeError: solver state lost", "--debug"]),
    (KeyboardInterrupt(), 130, ["interrupted", "--resume"]),
    (inference.CheckpointError("run.ckpt: checksum mismatch"), 2, ["error: run.ckpt: checksum mismatch"]),
], ids=["unexpected", "ctrl-c", "checkpoint"])
def test_the_handler_gives_one_line_or_with_debug_the_traceback(capsys, error, status, words):
    @command
    def main(argv):
        raise error

    assert main([]) == status
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and all(w in lines[0] for w in words), lines
    with pytest.raises(type(error)):
        main(["--debug"])


# ------------------------------------------------------------------------------------------------ friction
def test_the_compile_message_is_said_once_when_a_kernel_cache_is_cold(tmp_path, capsys, monkeypatch):
    from constitutive import ANICREEP, ModifiedCamClay

    assert [f.name for f in runner.kernel_files(ModifiedCamClay)] == ["_mcc_kernel.py"]
    assert [f.name for f in runner.kernel_files(ANICREEP, fe=True)] == ["_anicreep_kernel.py", "_anicreep_steps.py",
                                                                        "_residual_kernel.py"]
    cold = tmp_path / "_cold_kernel.py"
    cold.write_text("")
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setattr(runner, "_announced", set())
    (tmp_path / "__pycache__").mkdir()
    (tmp_path / "__pycache__" / "_warm_kernel.f-1.py311.nbi").write_bytes(b"")
    warm_ups = []

    def warm_up():
        warm_ups.append(time.perf_counter())
        time.sleep(0.2)

    runner.announce_compilation([tmp_path / "_warm_kernel.py"], warm_up)
    assert capsys.readouterr().err == "" and warm_ups == []
    t0 = time.perf_counter()
    runner.announce_compilation([tmp_path / "_warm_kernel.py", cold], warm_up)
    elapsed = time.perf_counter() - t0
    runner.announce_compilation([cold], warm_up)
    first, second = capsys.readouterr().err.splitlines()
    assert first == "compiling the constitutive kernels (_cold_kernel.py; first run only, cached afterwards)..."
    assert len(warm_ups) == 1
    # the time said is the warm-up's, measured: between the sleep inside it and the whole call around it
    said = float(re.fullmatch(r"compiled: the first forward evaluation took (\S+) s, compilation included",
                              second).group(1))
    assert 0.2 - 0.05 <= said <= elapsed + 0.05
    # a class of another model, later in the same process (the loop's enriched classes): its own cold kernels
    other = tmp_path / "_other_steps.py"
    other.write_text("")
    runner.announce_compilation([cold, other], warm_up)
    assert capsys.readouterr().err.splitlines()[0] == ("compiling the constitutive kernels (_other_steps.py; first "
                                                      "run only, cached afterwards)...")
    assert len(warm_ups) == 2
    # with NUMBA_CACHE_DIR set, numba keeps its cache there alone: an index beside the source does not count
    elsewhere = tmp_path / "numba_cache"
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(elsewhere))
    assert runner.uncached([tmp_path / "_warm_kernel.py"]) == [tmp_path / "_warm_kernel.py"]
    (elsewhere / "tmp_abc").mkdir(parents=True)
    (elsewhere / "tmp_abc" / "_warm_kernel.f-1.py311.nbi").write_bytes(b"")
    assert runner.uncached([tmp_path / "_warm_kernel.py", cold]) == [cold]


# ------------------------------------------------------------------------------------------------ valid variants
def _curves(observations):
    return {(t.name, c): (curve.x, curve.y) for t in observations for c, curve in t.curves.items()}


@pytest.mark.parametrize("toml", [LAB_TOML, PROGRAMME_TOML], ids=["flat", "programme"])
@pytest.mark.parametrize("csv", [v for _, v in LAB_VARIANTS], ids=[n for n, _ in LAB_VARIANTS])
def test_valid_lab_variants_load_to_the_same_values(tmp_path, csv, toml):
    (tmp_path / "plain").mkdir()
    plain = _curves(load_observations(load_study(_lab(tmp_path / "plain", toml=toml)).tests)[0])
    variant = _curves(load_observations(load_study(_lab(tmp_path, toml=toml, csv=csv)).tests)[0])
    assert plain.keys() == variant.keys()
    for key, (x, y) in plain.items():
        np.testing.assert_allclose(variant[key][0], x, rtol=1e-15)
        np.testing.assert_allclose(variant[key][1], y, rtol=1e-15)  # MPa * 1000: exact to round-off


@pytest.mark.parametrize("csv", [v for _, v in SBP_VARIANTS], ids=[n for n, _ in SBP_VARIANTS])
def test_valid_sbp_variants_load_to_the_same_values(tmp_path, csv):
    plain = _curves(load_sbp_recordings({"fast": _sbp_file(tmp_path)}, pore_pressure=True))
    path = tmp_path / "variant.csv"
    path.write_bytes(csv)
    variant = _curves(load_sbp_recordings({"fast": path}, pore_pressure=True))
    assert plain.keys() == variant.keys()
    for key, (x, y) in plain.items():
        np.testing.assert_allclose(variant[key][0], x, rtol=1e-15)
        np.testing.assert_allclose(variant[key][1], y, rtol=1e-15)


# ------------------------------------------------------------------------------------------------ real processes
def _run(args, cwd):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", *map(str, args)], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=120)


def test_a_pickle_checkpoint_never_runs_code_in_a_real_process(tmp_path):
    marker = tmp_path / "MARKER"
    out = tmp_path / "out"
    out.mkdir()
    (out / "run.ckpt").write_bytes(pickle.dumps(_RunsCode(marker)))
    proc = _run(["cases.calibrate", _lab(tmp_path), "--quick", "--processes", "1", "--out", out, "--resume"],
                tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.count("\n") == 1 and "run.ckpt" in proc.stderr and "Traceback" not in proc.stderr
    assert not marker.exists() and sorted(p.name for p in out.iterdir()) == ["run.ckpt"]


def test_burswood_recordings_in_latin1_in_a_real_process(tmp_path):
    path = tmp_path / "fast.csv"
    path.write_bytes("# mesurée\n".encode("latin-1") + SBP_CSV.encode())
    proc = _run(["cases.burswood_sbp", "--quick", "--recordings", f"fast={path}", "--out", tmp_path / "out"],
                tmp_path)
    assert proc.returncode == 2 and proc.stderr.startswith("error: ") and proc.stderr.count("\n") == 1, proc.stderr
    assert "fast.csv" in proc.stderr and "not UTF-8" in proc.stderr and not (tmp_path / "out").exists()


def test_debug_shows_the_traceback(tmp_path):
    study = _lab(tmp_path, toml=LAB_TOML.replace("M = [0.8, 1.8]", "M = [1.8, 0.8]"))
    quiet = _run(["cases.calibrate", study, "--out", tmp_path / "out"], tmp_path)
    loud = _run(["cases.calibrate", study, "--out", tmp_path / "out", "--debug"], tmp_path)
    assert quiet.returncode == 2 and "Traceback" not in quiet.stderr and "model.free.M" in quiet.stderr
    assert loud.returncode != 0 and "Traceback" in loud.stderr and "StudyError" in loud.stderr


def test_a_signalled_run_keeps_its_progress_and_resumes_with_one_wall_time(tmp_path):
    """SIGTERM: exit 75, progress.json and failed_solves.jsonl beside the checkpoint, --resume named; the resumed
    run's stdout wall_s is summary.json's (summed over both sessions)."""
    import signal

    out = tmp_path / "out"
    argv = [sys.executable, "-m", "cases.calibrate", _lab(tmp_path), "--quick", "--processes", "1", "--samples", "60",
            "--out", out]
    proc = subprocess.Popen(list(map(str, argv)), cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(ROOT)},
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    log = out / "progress.log"
    deadline = time.monotonic() + 60
    while not (log.exists() and log.read_text().count("stage") >= 2) and time.monotonic() < deadline:
        time.sleep(0.05)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 75, err
    assert "--resume" in err and "Traceback" not in err
    assert {"run.ckpt", "progress.json", "failed_solves.jsonl"} <= {p.name for p in out.iterdir()}
    resumed = _run(["cases.calibrate", *map(str, argv[3:]), "--resume"], tmp_path)
    assert resumed.returncode == 0, resumed.stderr
    *_, json_line, last = resumed.stdout.strip().splitlines()
    line = json.loads(json_line)
    assert last == f"report: {out / 'report.md'}" and (out / "report.md").is_file()
    summary = json.loads((out / "summary.json").read_text())
    assert line["wall_s"] == round(summary["wall_s"], 1) and line["wall_s"] >= line["wall_s_this_session"]
    assert not (out / "progress.json").exists() and not (out / runner.LOCK_FILE).exists()

