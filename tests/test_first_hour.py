"""The first-hour sequence (`tests/first_hour.py`) from a fresh interpreter, outside the checkout."""

import subprocess
import sys
from pathlib import Path


def test_a_researchers_first_hour_runs_from_a_fresh_interpreter(tmp_path):
    script = Path(__file__).with_name("first_hour.py")
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.rstrip().endswith("first hour: done") and (tmp_path / "grasp.gif").stat().st_size > 1000
    assert "Traceback" not in done.stderr and "Warning" not in done.stderr
