"""The studies' shared runner: results kept under the keys of what made them, reused, recomputed when the key
changes; a study configured, and extended by subclassing, without a copied script."""

import numpy as np
import pytest

from graspmanifold.base.io import load_npz, save_npz
from graspmanifold.studies.experience_study import ExperienceStudy, ExperienceStudyConfig
from graspmanifold.studies.runner import StudyRun


def test_a_kept_result_is_reused_under_its_key_and_recomputed_under_another(tmp_path):
    run = StudyRun(tmp_path, workers=1)
    made = []

    def compute(value):
        def make():
            made.append(value)
            return np.full(3, value)
        return make

    read = lambda path: (lambda a, m: (a["x"], m))(*load_npz(path, "demo", {"x": (3,)}))  # noqa: E731
    write = lambda x, path, meta: save_npz(path, "demo", {"x": x}, meta)  # noqa: E731
    first = run.keep("sub/x.npz", "key-a", compute(1.0), read, write)
    again = run.keep("sub/x.npz", "key-a", compute(2.0), read, write)
    assert made == [1.0] and np.array_equal(first, again) and (run.computed, run.reused) == (1, 1)
    with pytest.warns(UserWarning, match="discarded .*x.npz"):
        other = run.keep("sub/x.npz", "key-b", compute(3.0), read, write)
    assert made == [1.0, 3.0] and other[0] == 3.0
    (tmp_path / "sub" / "x.npz").write_bytes(b"truncated")
    with pytest.warns(UserWarning, match="could not be read"):
        assert run.keep("sub/x.npz", "key-b", compute(4.0), read, write)[0] == 4.0


def test_a_study_is_configured_and_extended_by_subclassing(tmp_path):
    class OnlyTheHeuristic(ExperienceStudy):
        def strategies(self, preshapes):
            return {"none": None}

    study = OnlyTheHeuristic(ExperienceStudyConfig(quick=True, out=str(tmp_path), workers=1))
    assert study.config.postures_per_object == 7 and study.config.doc_path == tmp_path / "experience_study.md"
    assert study.strategies({"preshape_tripod": np.zeros(22)}) == {"none": None}
    assert study.objects == ("box", "marble")
    with pytest.raises(ValueError, match="workers"):
        ExperienceStudyConfig(workers=0)


def test_a_further_seed_makes_the_experience_anew_in_its_own_files(tmp_path):
    """The seeds of the experience study: seed 0's files keep their names, a further seed's experience is generated
    from its own seed and kept beside them."""
    study = ExperienceStudy(ExperienceStudyConfig(quick=True, out=str(tmp_path), workers=1, postures=1))
    study.objects = ("box",)
    assert study.config.seed_count == 2 and ExperienceStudyConfig().seed_count == 3
    first, _ = study.experience()
    again, _ = study.experience(1)
    assert (tmp_path / "experience_box.npz").exists() and (tmp_path / "experience_box_seed1.npz").exists()
    assert not np.array_equal(first.postures, again.postures)


def test_a_study_run_from_python_holds_its_folder(tmp_path):
    """The lock was the command's: a study started from a notebook could write a folder another study writes."""
    from graspmanifold.base.errors import OutputInUse
    from graspmanifold.base.io import LOCK_FILE, output_lock

    with output_lock(tmp_path / LOCK_FILE, tmp_path):
        with pytest.raises(OutputInUse, match="being written by another"):
            ExperienceStudy(ExperienceStudyConfig(quick=True, out=str(tmp_path), workers=1)).run()
    assert not (tmp_path / "config.toml").exists()


def test_a_benchmark_like_study_keeps_what_it_prints_in_its_folder(tmp_path):
    """A study on the template (`runner.run_study`): the spring-hold diagnosis on four cylinder candidates writes its
    report where asked and keeps its printed output in its folder; its folder is released when it ends."""
    from graspmanifold.studies import spring_holds

    out, doc = tmp_path / "study", tmp_path / "report.md"
    spring_holds.main(["--objects", "cylinder", "--n", "4", "--workers", "1", "--out", str(out), "--doc", str(doc)])
    report, kept = doc.read_text(), (out / "spring_holds.log").read_text()
    assert "| cylinder |" in report and "| cylinder |" in kept and "cylinder: done" in kept
    assert sorted(p.name for p in out.iterdir()) == ["spring_holds.log"]  # no lock left
