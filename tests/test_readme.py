"""The README's Python blocks run as written, from a directory outside the checkout."""

import re
import subprocess
import sys
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def test_every_python_block_runs_verbatim(tmp_path):
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)
    assert len(blocks) >= 3
    outputs = []
    for number, block in enumerate(blocks):
        done = subprocess.run([sys.executable, "-c", block], cwd=tmp_path, capture_output=True, text=True,
                              timeout=600)
        assert done.returncode == 0, f"README block {number} failed:\n{block}\n{done.stderr[-3000:]}"
        outputs.append(done.stdout.splitlines())
    worked = outputs[next(i for i, b in enumerate(blocks) if "GraspController" in b)]
    assert len(worked) == 2 and "distal" in worked[1]
    assert (tmp_path / "grasp.gif").stat().st_size > 1000
