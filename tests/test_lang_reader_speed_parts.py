"""The reader's faster parts give what the plain ones give: the grammar's own tokens from the
scanner, every byte of a file from the bounded read, and the same forms from the written-out
repetition of the grammar."""

from __future__ import annotations

import os
from functools import lru_cache
from pathlib import Path

import pytest
from lark import Lark

from atlas_rap.errors import read_at_most
from atlas_rap.lang import reader
from atlas_rap.lang.reader import SList, read_text
from atlas_rap.logic import String, Var

REPO = Path(__file__).resolve().parent.parent
SHARED_PDDL = REPO.parent / "shared" / "data" / "pddl"


def shipped_texts() -> list[Path]:
    files = sorted((REPO / "rap_library").rglob("*.rap")) + sorted((REPO / "rap_library").rglob("*.ap"))
    files += sorted((REPO / "tests").rglob("*.rap"))
    files += sorted(SHARED_PDDL.rglob("p0*.pddl"))[:40] + sorted(SHARED_PDDL.rglob("domain*.pddl"))
    return files


@lru_cache(maxsize=1)
def lark_basic() -> Lark:
    return Lark(reader.GRAMMAR.read_text(encoding="utf-8"), parser="lalr", lexer="basic")


def lark_tokens(text: str) -> list[tuple]:
    """The tokens Lark's own ``basic`` lexer gives for grammar.lark."""
    return [(t.type, t.value, t.line, t.column, t.start_pos) for t in lark_basic().lex(text)]


def scanner_tokens(text: str) -> list[tuple]:
    scanner = reader._parser().parser.lexer.lexer
    return [(t.type, t.value, t.line, t.column, t.start_pos) for t in scanner.lex(text)]


def test_the_scanner_gives_lark_s_tokens_on_every_shipped_file():
    files = shipped_texts()
    assert len(files) > 60
    for path in files:
        text = path.read_text(encoding="utf-8")
        assert scanner_tokens(text) == lark_tokens(text), path


def test_the_scanner_counts_lines_across_strings_and_comments_that_span_them():
    text = '(a "x\ny" ; note\n #| block\n\n|# b)\n(c)'
    assert scanner_tokens(text) == lark_tokens(text)
    assert [(kind, line, column) for kind, _, line, column, _ in scanner_tokens(text)][-5:] == [
        ("ATOM", 5, 4), ("RPAR", 5, 5), ("LPAR", 6, 1), ("ATOM", 6, 2), ("RPAR", 6, 3)]


def test_the_scanner_gives_lark_s_positions_on_a_long_line_and_the_lines_after_it():
    text = "(init " + " ".join(f"(p o{i} ; x\n)" if i % 97 == 0 else f"(p o{i})" for i in range(3000)) + ")\n (b\n c)"
    assert scanner_tokens(text) == lark_tokens(text)


def test_a_character_no_terminal_takes_is_the_reader_s_located_error():
    with pytest.raises(Exception) as caught:
        read_text('(a\n  b "open', "x.rap")
    assert "x.rap:2:5: error: unterminated string" in str(caught.value)


def test_the_written_out_repetition_reads_lists_as_before():
    forms = read_text('(a (b "s" ?v) () c) x "top"')
    first, atom, string = forms
    assert type(first) is SList and first.items[0] == "a" and first.items[2].items == () and first.items[3] == "c"
    assert first.items[1].items == ("b", String("s"), Var("v"))
    assert first.locs == ((1, 2), (1, 4), (1, 15), (1, 18))
    assert (atom, string) == ("x", String("top"))
    assert read_text("; only a comment") == []


def test_read_at_most_reads_a_whole_file_and_one_byte_past_the_limit(tmp_path):
    small = tmp_path / "small.pddl"
    small.write_bytes(b"(define)\n" * 100)
    assert read_at_most(small, 10_000) == small.read_bytes()
    assert read_at_most(small, 899) == small.read_bytes()[:900]  # one past the limit: too large
    assert read_at_most(small, 900) == small.read_bytes()


def test_read_at_most_stops_on_a_device_that_never_ends():
    assert len(read_at_most("/dev/zero", 100_000)) == 100_001


def test_read_at_most_raises_the_os_error_of_a_missing_file_or_a_folder(tmp_path):
    with pytest.raises(FileNotFoundError):
        read_at_most(tmp_path / "missing", 10)
    with pytest.raises(IsADirectoryError):
        read_at_most(tmp_path, 10)
    assert not os.listdir(tmp_path)
