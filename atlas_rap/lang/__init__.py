"""Reading RAP (.rap) and AP (.ap) files: grammar, reader, AST, validator.

The flat API: :func:`load` a program with its includes (:func:`load_text` for typed text), :func:`parse_text` /
:func:`parse_file` one file, :func:`parse_term` one term, :func:`read_text` the raw s-expressions, and
:func:`format_node` / :func:`format_file` to print AST nodes back as source.
Errors are :class:`~atlas_rap.errors.LanguageError` (a :class:`~atlas_rap.errors.SourceError`) with every problem
located.
"""

from atlas_rap.errors import AtlasError, LanguageError, Problem, SourceError, SourceLocation
from atlas_rap.lang import ast
from atlas_rap.lang.loader import Program, load, load_text, parse_file, parse_term, parse_text
from atlas_rap.lang.printer import format_file, format_node
from atlas_rap.lang.reader import SList, read_file, read_text
from atlas_rap.lang.validator import to_term, validate

__all__ = [
    "AtlasError", "LanguageError", "Problem", "Program", "SList", "SourceError", "SourceLocation", "ast",
    "format_file", "format_node", "load", "load_text", "parse_file", "parse_term", "parse_text", "read_file", "read_text",
    "to_term", "validate",
]
