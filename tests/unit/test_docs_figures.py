"""Every figure the docs cite is one docs/figures/make.py makes (a figure the command no longer
makes, still cited, fails here), and every block of numbers in docs/ marked as the script's is
one it writes."""
import importlib.util
import re

from scenes import ROOT

DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def make():
    spec = importlib.util.spec_from_file_location("docs_figures_make", ROOT / "docs" / "figures" / "make.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def cited() -> dict[str, list[str]]:
    """docs/figures files cited by each document (links and paths), relative to docs/figures."""
    out = {}
    for doc in DOCS:
        text = doc.read_text(encoding="utf-8")
        names = re.findall(r"(?:docs/)?figures/([\w./-]+\.(?:png|svg|jpg))", text)
        if names:
            out[doc.name] = names
    return out


def test_every_cited_figure_is_made_by_the_script_and_is_there():
    made = set(make().outputs())
    for doc, names in cited().items():
        for name in names:
            assert name in made, f"{doc} cites docs/figures/{name}, which docs/figures/make.py does not make"
            assert (ROOT / "docs" / "figures" / name).is_file(), name
    on_disk = {p.relative_to(ROOT / "docs" / "figures").as_posix() for p in (ROOT / "docs" / "figures").rglob("*.png")}
    assert on_disk <= made, sorted(on_disk - made)  # no picture left behind that nothing makes


def test_the_scripts_blocks_are_in_the_docs_and_nothing_else_claims_it():
    module = make()
    text = (ROOT / "docs" / "studies.md").read_text(encoding="utf-8")
    opened = re.findall(r"<!-- make.py:(\w+) -->", text)
    closed = re.findall(r"<!-- /make.py:(\w+) -->", text)
    assert sorted(opened) == sorted(closed) == sorted(module.BLOCKS.values())
    assert set(module.BLOCKS) <= set(module.PARTS)
    for name in opened:  # each block was written: it holds text and a date
        block = text.split(f"<!-- make.py:{name} -->")[1].split(f"<!-- /make.py:{name} -->")[0]
        assert re.search(r"20\d\d-\d\d-\d\d", block), name


def test_the_paper_part_names_what_tribofmu_figures_writes():
    from tribofmu.figures import FIGURES, output_names
    names = output_names(make().PAPER)
    assert "fig2.png" in names and "tn_map.png" in names
    assert [n for n in names if n.startswith("friction_")] == [f"friction_{r.label}.png" for r in FIGURES["friction"]]
