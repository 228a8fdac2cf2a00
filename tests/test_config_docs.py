"""Every key of the config schema is described (config/keys.py), and nothing else is."""

from vplotter.config import SCHEMA
from vplotter.config.keys import DESCRIPTIONS, SECTIONS


def test_every_schema_key_has_a_description():
    missing = [f"{s}.{k}" for s, keys in SCHEMA.items() for k in keys
               if not DESCRIPTIONS.get(f"{s}.{k}", "").strip()]
    assert missing == []


def test_no_description_names_a_missing_key():
    known = {f"{s}.{k}" for s, keys in SCHEMA.items() for k in keys}
    assert sorted(set(DESCRIPTIONS) - known) == []


def test_every_section_is_described_and_no_other():
    assert set(SECTIONS) == set(SCHEMA)
    assert all(text.strip() for text in SECTIONS.values())


def test_descriptions_are_one_line():
    assert [k for k, text in DESCRIPTIONS.items() if "\n" in text or "|" in text] == []


def test_the_reference_in_configuration_md_is_current():
    """docs/configuration.md holds the generated tables (readable on GitHub); after a schema
    change `python docs/hooks/config_reference.py` writes them anew."""
    import importlib.util
    from pathlib import Path

    hook = Path(__file__).resolve().parent.parent / "docs" / "hooks" / "config_reference.py"
    spec = importlib.util.spec_from_file_location("config_reference", hook)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    text = mod.PAGE.read_text(encoding="utf-8")
    assert "| `anchor_distance_mm` |" in text
    assert mod.render(text) == text, "run: python docs/hooks/config_reference.py"
    stale = text.replace("| `anchor_distance_mm` |", "| `anchor_distance` |")
    assert mod.render(stale) == text
