"""Readout Markdown (app/readout.py): pipe tables, escaping, presenter size."""

from __future__ import annotations

from rigidlab.app.readout import markdown_to_html, one_digit


def test_pipe_table_aligns_and_escapes() -> None:
    text = "before\n\n| # | f (Hz) | note |\n|---:|---:|:---:|\n| **1** | 0.5 | <b> |\n| 2 | 1.5 | a&b |\nafter"
    out = markdown_to_html(text)
    assert out.startswith("<p style='margin:0 0 0.45em 0'>before </p><table")
    assert out.endswith("</table><p style='margin:0 0 0.45em 0'>after </p>")
    assert out.count("<tr>") == 3 and out.count("<th ") == 3 and out.count("<td ") == 6
    head = ";border-bottom:1px solid #c8ccd4;font-weight:600'>"
    assert f"text-align:right{head}f (Hz)</th>" in out and f"text-align:center{head}note</th>" in out
    assert "<td style='padding:0.1em 0.45em;text-align:right'><b>1</b></td>" in out
    assert "&lt;b&gt;" in out and "a&amp;b" in out and "<b>" not in out.replace("<b>1</b>", "")


def test_lines_with_bars_but_no_rule_row_stay_text() -> None:
    # norms in other scenes' readouts: |p| = 1, |det G| = ...
    for text in ("|p| = 1: unit Euler parameters.", "|det G| = 0.5\n|p| = 1", "| a | b |\n| 1 | 2 |"):
        out = markdown_to_html(text)
        assert "<table" not in out and out.startswith("<p ")
    assert "|p| = 1: unit Euler parameters." in markdown_to_html("|p| = 1: unit Euler parameters.")


def test_one_digit_reads_round_off_as_below_its_floor():
    assert one_digit(0.0) == "0" and one_digit(-3.2e-7) == "3e-07"
    # a residual at round-off reads the same whatever its value (4e-34, 0 or 1e-17 frame to frame)
    assert one_digit(4e-34, 1e-15) == one_digit(0.0, 1e-15) == one_digit(-1e-17, 1e-15) == "< 1e-15"
    assert one_digit(2e-12, 1e-15) == "2e-12"
