"""The command line: two commands for a new user, one readable line for an error."""

import subprocess
import sys

import cadpipe


def test_python_m_cadpipe_reports_usage_errors_with_exit_2():
    run = subprocess.run([sys.executable, "-m", "cadpipe", "no-such-command"],
                         capture_output=True, text=True)
    assert run.returncode == 2
    assert "invalid choice" in run.stderr


def test_user_error_is_one_line_without_traceback(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    run = subprocess.run([sys.executable, "-m", "cadpipe", "demo", "-o", str(blocker / "x")],
                         capture_output=True, text=True)
    assert run.returncode == 1
    assert "Traceback" not in run.stderr
    assert len(run.stderr.strip().splitlines()) == 1


def test_outputs_get_ordinary_file_permissions(tmp_path):
    import os

    out = cadpipe.Pipe([[0, 0, 0], [1, 0, 0]], 0.1).mesh().export(tmp_path / "p.stl")
    mask = os.umask(0)
    os.umask(mask)
    assert os.stat(out).st_mode & 0o777 == 0o666 & ~mask
