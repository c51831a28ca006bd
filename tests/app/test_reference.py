"""The generated reference pages (docs/techniques.md, docs/options.md) are current: each is
regenerated in memory from the declarations and compared with the committed file."""
from app import reference


def test_generated_pages_are_current():
    stale = reference.stale()
    assert not stale, f"{', '.join(stale)} not current: run `{reference.COMMAND}` and commit"


def test_every_technique_and_option_is_on_its_page():
    from app.techniques import REGISTRY
    pages = reference.pages()
    for t in REGISTRY.values():
        assert f"## `{t.name}`" in pages["docs/techniques.md"]
        for s in t.Options.specs():
            assert f"## `{s.flag}`" in pages["docs/options.md"]
    assert "Russian roulette" in pages["docs/options.md"]      # --stochastic's docstring
    assert "intended loss" in pages["docs/options.md"]         # --cap-policy's docstring
