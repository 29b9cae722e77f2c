"""``python -m pyflyt_cli.commands.env_manuals DOC.md`` rewrites the env manuals between a
document's markers, says when it is already up to date, and refuses other arguments."""

from __future__ import annotations

from pyflyt_cli.commands import env_manuals
from pyflyt_engine.envs import manual
from pyflyt_engine.envs.manual import BEGIN_MARKER, END_MARKER


def test_regenerates_the_section_then_finds_it_up_to_date(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(manual, "manuals_markdown", lambda: "### `X`\n\nthe manual\n")
    doc = tmp_path / "environments.md"
    doc.write_text(f"# Environments\n\nprose\n\n{BEGIN_MARKER}\nstale\n{END_MARKER}\n\nmore prose\n")
    assert env_manuals.main([str(doc)]) == 0
    assert doc.read_text() == (
        f"# Environments\n\nprose\n\n{BEGIN_MARKER}\n\n### `X`\n\nthe manual\n\n{END_MARKER}\n\nmore prose\n"
    )
    assert f"updated the env manuals in {doc}" in capsys.readouterr().out
    assert env_manuals.main([str(doc)]) == 0
    assert f"{doc} is up to date" in capsys.readouterr().out


def test_a_document_without_the_markers_is_refused(tmp_path, capsys):
    doc = tmp_path / "other.md"
    doc.write_text("# no markers\n")
    assert env_manuals.main([str(doc)]) == 2
    assert f"error: {doc}: the document has no <!-- BEGIN GENERATED ENV MANUALS" in capsys.readouterr().err
    assert doc.read_text() == "# no markers\n"


def test_usage(capsys):
    assert env_manuals.main([]) == 2
    assert "usage: python -m pyflyt_cli.commands.env_manuals docs/environments.md" in capsys.readouterr().err
