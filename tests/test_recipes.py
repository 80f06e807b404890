"""docs/guide/recipes.md runs as written, from an empty folder (its own file: the suite's workers take it beside the
README's blocks)."""

import re
import subprocess
import sys
from pathlib import Path

RECIPES = Path(__file__).resolve().parents[1] / "docs" / "guide" / "recipes.md"


def test_the_recipes_run_as_written(tmp_path):
    """docs/guide/recipes.md: every Python block runs as written from an empty folder, and leaves what it promises."""
    blocks = re.findall(r"```python\n(.*?)```", RECIPES.read_text(), flags=re.S)
    assert len(blocks) == 7
    for number, block in enumerate(blocks):
        done = subprocess.run([sys.executable, "-c", block], cwd=tmp_path, capture_output=True, text=True,
                              timeout=600)
        assert done.returncode == 0, f"recipe {number} failed:\n{block}\n{done.stderr[-3000:]}"
        assert done.stdout.strip(), f"recipe {number} printed nothing"
    assert (tmp_path / "bottle.urdf").is_file() and len(list((tmp_path / "grasps").glob("*.npy"))) == 4
    assert (tmp_path / "cylinder.gif").stat().st_size > 1000
    assert gm_load(tmp_path / "ukr.npz").latent_dim == 2


def gm_load(path: Path):
    from graspmanifold.manifold.representations import load_representation

    return load_representation(path)
