"""bench/sections.py: a bench's generated section replaces its own text only (the other sections and markers kept)."""

from __future__ import annotations

from bench.sections import replace_section

DOC = """# Properties

## First (issue 1)

old first

## Middle (issue 34)

old middle
| a | b |

<!-- other: begin -->
## Other
kept
<!-- other: end -->
"""


def test_a_middle_section_is_replaced_and_the_rest_kept(tmp_path):
    out = tmp_path / "doc.md"
    out.write_text(DOC)
    replace_section(out, "## Middle (issue 34)", ["## Middle (issue 34)", "", "new middle", ""])
    text = out.read_text()
    assert "new middle" in text and "old middle" not in text
    assert "old first" in text and "<!-- other: begin -->\n## Other\nkept\n<!-- other: end -->" in text
    # the same section written again leaves the document as it was
    before = text
    replace_section(out, "## Middle (issue 34)", ["## Middle (issue 34)", "", "new middle", ""])
    assert out.read_text() == before


def test_the_first_section_is_replaced_up_to_the_next_and_a_new_one_appended(tmp_path):
    out = tmp_path / "doc.md"
    out.write_text(DOC)
    replace_section(out, "## First (issue 1)", ["## First (issue 1)", "", "new first"])
    assert "new first\n\n## Middle (issue 34)" in out.read_text()
    replace_section(out, "## Last", ["## Last", "", "appended"])
    assert out.read_text().endswith("<!-- other: end -->\n\n## Last\n\nappended\n")
