"""The documentation: the API reference builds with warnings as errors, every public name has a docstring,
the tutorial page is the stored getting-started notebook."""

import inspect
import subprocess
import sys
from pathlib import Path

import graspmanifold as gm

ROOT = Path(__file__).resolve().parents[1]


def test_the_site_builds_with_warnings_as_errors_and_opens_from_its_files(tmp_path):
    """From site/index.html every navigation link opened a directory listing under file://, a script came from a
    network, the API reference was one page 101,000 pixels tall, the studies were not in the site, and the
    tutorial printed its GIF's path and had nothing on meshes, experience, comparisons or one's own code."""
    import re
    from urllib.parse import urljoin, urlparse

    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    site = tmp_path / "site"
    page = (site / "api" / "manifold.html").read_text()
    assert "graspmanifold.manifold.som.SOM" in page and "masked" in page
    pages = sorted(site.rglob("*.html"))
    assert {"experience_study.html", "protocols.html", "structure.html", "tutorial.html"} <= {p.name for p in pages}
    home = (site / "index.html").read_text()  # the navigation is built from docs/'s folders: every page is in it
    linked = {urlparse(link).path for link in re.findall(r'href="([^"#]+)', home)}
    unreachable = [str(page.relative_to(ROOT / "docs")) for page in sorted((ROOT / "docs").rglob("*.md"))
                   if page.relative_to(ROOT / "docs").with_suffix(".html").as_posix() not in linked]
    assert unreachable == [], f"docs pages the site's navigation does not reach: {unreachable}"
    tutorial = (site / "tutorial.html").read_text()
    shown = re.findall(r'<img[^>]+src="([^"]+\.gif)"', tutorial)  # the GIF shown, not its path printed
    assert shown and all((site / link).is_file() for link in shown), shown
    missing = [words for words in ("epsilon is 0.000", "make_object", "PostureDatabase", "McNemar", "Blend",
                                   "CloseUntilTouch") if words not in tutorial]
    assert not missing, f"the tutorial lacks {missing}"
    for html in (p for p in pages if p.name != "404.html"):  # a server's page, its links from the site's root
        text = html.read_text()
        assert not re.search(r"<script[^>]+src=\"(https?:)?//", text), f"{html.name} loads a script from a network"
        for link in re.findall(r'href="([^"#]+)', text):
            if urlparse(link).scheme or link.startswith("//"):
                continue  # a link out of the site
            target = Path(urlparse(urljoin(html.as_uri(), link)).path)
            assert target.is_file(), f"{html.relative_to(site)} links {link}, which opens no file under file://"


def test_every_module_is_in_the_reference_and_every_public_name_has_a_docstring():
    api = "\n".join(p.read_text() for p in sorted((ROOT / "docs" / "api").glob("*.md")))
    package_dir = ROOT / "src" / "graspmanifold"
    modules = {".".join(p.relative_to(package_dir).with_suffix("").parts) for p in package_dir.rglob("*.py")
               if p.name != "__init__.py"}
    assert [m for m in sorted(modules) if f"::: graspmanifold.{m}\n" not in api] == []
    import griffe  # what the reference is built with: it reads the docstrings of constants too

    package = griffe.load("graspmanifold", search_paths=[str(ROOT / "src")])
    assert [name for name in gm.__all__ if not package[name].docstring] == []
    assert all(inspect.getdoc(getattr(gm, name)) for name in gm.__all__
               if inspect.isclass(getattr(gm, name)) or inspect.isfunction(getattr(gm, name)))


def test_the_tutorial_page_is_the_stored_notebook_and_the_notebooks_are_stored_executed():
    import nbformat

    done = subprocess.run([sys.executable, str(ROOT / "scripts" / "execute_notebooks.py"), "--check"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    for path in sorted((ROOT / "examples").glob("*.ipynb")):
        notebook = nbformat.read(path, as_version=4)
        code = [cell for cell in notebook.cells if cell.cell_type == "code"]
        assert all(cell.execution_count for cell in code), f"{path.name} is stored unexecuted"
        assert any(output.get("output_type") == "display_data" for cell in code for output in cell.outputs), path.name


def test_the_public_functions_and_methods_say_their_arguments():
    """`Args:` (with units) on every function of gm.__all__ that takes arguments, and on the public methods of
    its classes (a dataclass's fields are its arguments)."""
    import dataclasses

    missing = []
    for name in gm.__all__:
        thing = getattr(gm, name)
        members = [(name, thing)] if inspect.isfunction(thing) else [
            (f"{name}.{m}", f) for m, f in inspect.getmembers(thing, inspect.isfunction)
            if (not m.startswith("_") or (m == "__init__" and not dataclasses.is_dataclass(thing)))
            and f.__qualname__.split(".")[0] == thing.__name__] if inspect.isclass(thing) else []
        for label, function in members:
            takes = [p for p in inspect.signature(function).parameters if p not in ("self", "cls")]
            if takes and "Args:" not in (inspect.getdoc(function) or ""):  # an override may inherit its base's
                missing.append(label)
    assert missing == []
