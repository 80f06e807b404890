"""An MkDocs hook: the studies (with their figures) and the architecture page, which live in docs/ beside the site's own pages
(docs/site/), join the site, so its navigation reaches them (`mkdocs.yml` names this file under `hooks`)."""

from pathlib import Path

from mkdocs.structure.files import File

DOCS = Path(__file__).resolve().parent
#: the pages of docs/ that the site shows, by the section of its navigation
PAGES = ("recipes.md", "structure.md", "experience_study.md", "experience_study_paper_grids.md", "protocols.md",
         "generator_defaults.md", "generator_defaults_held_out.md", "hands.md", "hands_menagerie_without_meshes.md",
         "unseen_objects_paper.md", "unseen_objects_quick.md", "data_character.md", "spring_holds_by_design.md",
         "uncertainty_study.md", "uncertainty_study.png", "learning_curve.md", "learning_curve.png",
         "literal_controller.md", "completion_study.md", "completion_study_errors.png", "completion_study_ukr.png",
         "planned_grasps.md", "planned_grasps.png", "palm_follows_touch.md", "palm_follows_touch.png")


def on_files(files, config):
    for name in PAGES:
        files.append(File(name, src_dir=str(DOCS), dest_dir=config["site_dir"],
                          use_directory_urls=config["use_directory_urls"]))
    return files
