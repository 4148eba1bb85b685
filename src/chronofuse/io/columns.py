"""Numeric text columns read as the file says: compression by content, BOM, header, delimiter, decimal comma.

The layouts met in practice, each covered by a test in ``tests/io/test_records.py``:

- plain columns, one value per line or ``time value`` (Stable32 ``.dat`` files, e.g. ``PHASE.DAT``:
  numbers, sometimes indented, no header);
- a ``#`` or ``;`` comment block first (Keysight 53230A counter logs as in the GPS and Cs5071A records:
  ``#`` lines, CRLF line ends, ``+2.764966E-07`` style numbers; TimeLab exports: ``;`` lines);
- a header line of names, possibly behind a UTF-8 byte-order mark (spreadsheet CSV exports);
- a header block before it: lines of text that are not data (an instrument's export, 53230A/BenchVue,
  TimeMonitor and Stable32 ``.dat`` files with text header lines): kept as the layout's ``preamble``; the
  last of them is the header when it names as many columns as the data has;
- ``;`` or tab between columns with decimal commas (European spreadsheet exports: ``0;1,475``), and quoted
  fields with decimal commas between commas (``"0,5","1,25"``);
- date-time stamps in a column (ISO 8601, ``dd.mm.yyyy hh:mm:ss``), or a date and a clock time in two
  white-space separated fields, which are read as one time column (``pair``).

The file is *sniffed* (compression from its first bytes, then the first 64 KiB of text, decoded as
``utf-8-sig`` so a BOM never turns the first sample into a header) and then read in one pass by
pyarrow's multi-threaded CSV reader; layouts it cannot take (columns separated by runs of spaces,
comment lines or inline comments among the data) go to pandas' C parser. Only when a fast reader
refuses the text is the file parsed line by line in Python, to name the line that is wrong.

A comma between two digits is ambiguous: ``1,475`` is one number written with a decimal comma or the
two columns ``1`` and ``475``. A comma-separated two-column file without a header is read as (time,
value) only if its first column increases strictly and no second field has a leading zero (``1,05``);
otherwise it is refused with a message that says so. Decimal commas with ``;`` or tab between the
columns are unambiguous and read.
"""

from __future__ import annotations

import bz2
import csv
import gzip
import io
import lzma
import re
import warnings
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pcsv

from chronofuse.io.column_text import decimal_text_to_ns, float_values, stream_numeric_times
from chronofuse.io.timestamps import UTC_WORD, is_clock, is_date, is_date_time
from chronofuse.validation import InputDataError, InputWarning

__all__ = ["Layout", "sniff", "read_columns", "decimal_text_to_ns", "data_lines", "scan", "Scan", "WINDOWS_NAN"]

_SNIFF_BYTES = 1 << 16
_COMMENT = ("#", ";")
_NULLS = ["nan", "NaN", "NAN", "-nan", "+nan", "-NaN", "+NaN"]
_DECIMAL_COMMA = re.compile(r"^[+-]?\d*,\d+([eE][+-]?\d+)?$")
_MAGIC = (
    (b"\x1f\x8b", "gzip"),
    (b"BZh", "bz2"),
    (b"\xfd7zXZ\x00", "xz"),
    (b"PK\x03\x04", "zip"),
    (b"\x28\xb5\x2f\xfd", "zstd"),
)


@dataclass(frozen=True)
class Layout:
    """What the sniff found.

    Attributes
    ----------
    compression : str or None
        ``"gzip"``, ``"bz2"``, ``"xz"`` (from the file's first bytes, whatever its suffix) or None.
    delimiter : str or None
        ``","``, ``";"``, ``"\\t"``, ``" "`` (runs of white space) or None (one column).
    decimal_comma : bool
        Numbers are written with a decimal comma.
    header : list of str or None
        Column names, when the first non-comment line is not numeric.
    header_line : int
        Its 1-based line number (0 without a header).
    first_data_line : int
        1-based line number of the first data line.
    width : int
        Fields per data line (a date and a clock time in two fields count as two).
    preamble : tuple of (int, str)
        The text lines before the data (header block, header line included), with their line numbers.
    comments : tuple of (int, str)
        The ``#``/``;`` comment lines before the data.
    pair : int or None
        Index of a date field followed by a clock-time field: the two are one time column.
    quoted : bool
        Fields are quoted (``"0,5","1,25"``).
    rows : tuple of list of str
        The fields of the first data lines (up to 200) that the sniff read.
    trailing_empty : bool
        Every data line ends with the delimiter (``0,1.5,``): an empty last field, not counted in ``width``.
    d_exponent : bool
        Numbers are written with a Fortran ``D`` exponent (``1.23D-09``), read as ``E``.
    """

    compression: str | None
    delimiter: str | None
    decimal_comma: bool
    header: list[str] | None
    header_line: int
    first_data_line: int
    width: int
    preamble: tuple = ()
    comments: tuple = ()
    pair: int | None = None
    quoted: bool = False
    rows: tuple = ()
    trailing_empty: bool = False
    d_exponent: bool = False


def _compression(path: Path) -> str | None:
    with open(path, "rb") as fh:
        head = fh.read(8)
    for magic, name in _MAGIC:
        if head.startswith(magic):
            if name in ("zip", "zstd"):
                raise InputDataError(f"a {name} archive: extract the record first (gzip, bz2 and xz are read as they are)",
                                     str(path))
            return name
    return None


def open_binary(path: Path, compression: str | None):
    """A binary stream of the file's (decompressed) bytes."""
    if compression == "gzip":
        return gzip.open(path, "rb")
    if compression == "bz2":
        return bz2.open(path, "rb")
    if compression == "xz":
        return lzma.open(path, "rb")
    return open(path, "rb")


#: A Fortran ``D`` exponent (``1.23D-09``): read as ``E``.
_D_EXPONENT = re.compile(r"(?<=[\d.])[dD](?=[+-]?\d)")


def d_to_e(token: str) -> str:
    """``1.23D-09`` -> ``1.23E-09`` (a Fortran double's exponent); other text as it is."""
    return _D_EXPONENT.sub("E", token) if ("D" in token or "d" in token) else token


def _is_number(token: str) -> bool:
    try:
        float(d_to_e(token))
    except ValueError:
        return False
    return True


#: Windows C runtimes print NaN and infinity as ``1.#QNAN``, ``-1.#IND``, ``1.#INF``: read as a missing sample.
WINDOWS_NAN = re.compile(r"^[+-]?\d(\.\d*)?#(QNAN|SNAN|IND|INF)\d*$", re.IGNORECASE)
# A "#" that opens a comment: at the line's start or after white space or a separator; any other "#" is in a field.
_FIELD_HASH = re.compile(r"[^\s#,;]#")


class FieldHashError(ValueError):
    """A ``#`` inside a field that is no Windows NaN spelling (``1.#QNAN``): neither a comment nor a number."""


def _strip_comment(line: str) -> str:
    """``line`` without a ``;`` comment line or a ``#`` comment (a ``#`` inside quotes is text: "Reading #").

    A ``#`` opens a comment at the line's start or after white space or a separator. A field holding a
    ``#`` is a Windows NaN spelling (:data:`WINDOWS_NAN`, returned as ``nan``) or raises
    :class:`FieldHashError` (``1.#5`` is no number, and cutting it at the ``#`` would read it as 1)."""
    if line.lstrip().startswith(";"):
        return ""
    if '"' in line and "#" in line:
        inside = False
        for i, ch in enumerate(line):
            if ch == '"':
                inside = not inside
            elif ch == "#" and not inside:
                return line[:i].strip()
        return line.strip()
    if "#" not in line:
        return line.strip()
    if _FIELD_HASH.search(line):
        line = re.sub(r"[^\s,;]*#[^\s,;]*", _windows_nan, line, count=0)
    return line.split("#", 1)[0].strip()


def _windows_nan(match: re.Match) -> str:
    token = match.group(0)
    if token.startswith("#"):
        return token  # a comment's first word
    if WINDOWS_NAN.match(token):
        return "nan"
    raise FieldHashError(f"{token!r}: a '#' inside a field is neither a comment (which starts a line or follows "
                         "white space) nor a number")


def _split(line: str, delimiter: str | None) -> list[str]:
    """The fields of ``line``; quotes (``"0,5"``) are respected and removed."""
    if delimiter in (None, " "):
        return [t.strip('"') for t in line.split()]
    if '"' in line:
        return [t.strip() for t in next(csv.reader([line], delimiter=delimiter))]
    return [t.strip() for t in line.split(delimiter)]


def _is_value(token: str) -> bool:
    return _is_number(token) or bool(_DECIMAL_COMMA.match(token))


def _is_data(line: str) -> bool:
    """A line of numbers (possibly with date-time fields and quotes): every field reads, one is a number."""
    return _unreadable_token(line) is None


def _unreadable_token(line: str) -> str | None:
    """The first field of ``line`` that is no number, date or clock time ("" when no field is a number);
    None for a line of numbers. With ``;`` or a tab between the fields a comma is a decimal comma (also in
    a stamp's seconds: ``2023-03-26T00:00:00,000Z``); a clock time's ``UTC`` word is its zone."""
    line = UTC_WORD.sub(r"\1Z", line.replace('"', ""))
    separators = r"[;\t\s]+" if (";" in line or "\t" in line) else r"[,;\s]+"
    tokens = [t for t in re.split(separators, line) if t]
    values = [t for t in tokens if _is_value(t)]
    bad = next((t for t in tokens if not (_is_value(t) or is_date_time(t) or is_date(t) or is_clock(t))), None)
    if bad is not None:
        return bad
    return None if values else ""


def _guess_delimiter(lines: list[str]) -> str | None:
    if any("\t" in ln for ln in lines) and not any(";" in ln for ln in lines):
        return "\t" if all(len(ln.split("\t")) == len(lines[0].split("\t")) for ln in lines) else " "
    if any(";" in ln for ln in lines):
        return ";"
    spaced = [ln.split() for ln in lines]
    if any(len(t) > 1 for t in spaced) and all(_is_value(x) or is_date_time(x) or is_date(x) or is_clock(x)
                                               for t in spaced for x in t):
        return " "
    if any("," in ln for ln in lines):
        return ","
    return None


def sniff(path: Path) -> Layout:
    """Look at the file's first bytes and first 64 KiB of text; raise :class:`InputDataError` for what
    cannot be a numeric record (an archive, no data lines, a decimal comma that is ambiguous)."""
    compression = _compression(path)
    try:
        with open_binary(path, compression) as fh:
            raw = fh.read(_SNIFF_BYTES + 1)
    except (OSError, EOFError, lzma.LZMAError) as exc:
        raise InputDataError(f"cannot read file: {exc}", str(path)) from exc
    text = raw[:_SNIFF_BYTES].decode("utf-8-sig", errors="replace")
    lines = text.splitlines()
    if len(raw) > _SNIFF_BYTES and len(lines) > 1:
        lines = lines[:-1]  # the last line may be cut
    first, data, preamble, comments = 0, [], [], []
    for lineno, raw_line in enumerate(lines, start=1):
        if not first and raw_line.strip().startswith(_COMMENT):
            comments.append((lineno, raw_line.strip()))
            continue
        try:
            line = _strip_comment(raw_line)
        except FieldHashError as exc:
            raise InputDataError(str(exc), str(path), lineno) from None
        if not line:
            continue
        if not first:
            if not _is_data(line):
                preamble.append((lineno, line))
                continue
            first = lineno
        data.append((lineno, line))
        if len(data) >= 200:
            break
    if not data:
        if not preamble:
            raise InputDataError("no data lines (empty file, or only comments)", str(path))
        # name the first line that might have been data: the first holding a digit, else the first text line
        numeric = [(n, ln) for n, ln in preamble if any(ch.isdigit() for ch in ln)]
        if not numeric:
            raise InputDataError(f"no data lines (only comments and text lines; the first, {preamble[0][1][:60]!r}, "
                                 "holds no number)", str(path), preamble[0][0])
        lineno, line = numeric[0]
        bad = _unreadable_token(line)
        why = (f"{bad!r} is no number, date or time" if bad else "no field is a number")
        raise InputDataError(f"no line of the file reads as data: the first that could be ({line[:60]!r}) cannot "
                             f"be read ({why})", str(path), lineno)
    delimiter = _guess_delimiter([ln.replace('"', "") for _, ln in data])
    quoted = any('"' in ln for _, ln in data)
    tokens = [(lineno, _split(ln, delimiter)) for lineno, ln in data]
    # a delimiter at the end of every line (a spreadsheet's export): an empty last field, not a column
    trailing = delimiter in (",", ";", "\t") and all(len(row) > 1 and row[-1] == "" for _, row in tokens)
    if trailing:
        tokens = [(lineno, row[:-1]) for lineno, row in tokens]
    decimal_comma = (delimiter in (";", "\t", " ") or (delimiter == "," and quoted)) and any(
        _DECIMAL_COMMA.match(t) for _, row in tokens for t in row)
    width = len(tokens[0][1])
    pair = None
    if delimiter == " ":
        row = tokens[0][1]
        pair = next((i for i in range(width - 1) if is_date(row[i]) and is_clock(row[i + 1])), None)
    logical = width - (pair is not None)
    names, header_line = None, 0
    if preamble:
        candidate_line, candidate = preamble[-1]
        fields = [t for t in (_split(candidate, delimiter) if delimiter else [candidate.strip()]) if t]
        if delimiter == "," and len(preamble) == 1 and len(fields) != width and not quoted:
            raise InputDataError(
                f"header has {len(fields)} names but the first data line has {width} comma-separated values "
                f"({data[0][1]!r}): if the numbers use a decimal comma, separate the columns with ';' or a tab",
                str(path), data[0][0])
        if pair is not None and len(fields) == width:
            fields = fields[:pair] + [f"{fields[pair]} {fields[pair + 1]}"] + fields[pair + 2:]
        # A one-column file has no column count to vouch for a header: only a lone text line is one.
        if len(fields) == logical and (logical > 1 or len(preamble) == 1):
            names, header_line = fields, candidate_line
    if delimiter == "," and names is None and not quoted and len(preamble) == 0:
        _refuse_ambiguous_comma(path, tokens)
    for t in tokens[0][1]:
        if not (_is_number(t) or (decimal_comma and _is_number(t.replace(",", "."))) or is_date_time(t)
                or (pair is not None and (is_date(t) or is_clock(t)))):
            raise InputDataError(f"cannot read {t!r} as a number", str(path), data[0][0])
    d_exponent = any(_D_EXPONENT.search(t) is not None and _is_number(t) for _, row in tokens for t in row)
    return Layout(compression, delimiter, decimal_comma, names, header_line, first, width, tuple(preamble),
                  tuple(comments), pair, quoted, tuple(row for _, row in tokens), trailing, d_exponent)


def _refuse_ambiguous_comma(path: Path, tokens: list[tuple[int, list[str]]]) -> None:
    """A comma file without a header whose fields read better as decimal commas is refused."""
    widths = {len(row) for _, row in tokens}
    if not all(_is_number(t) for _, row in tokens for t in row):
        return  # a date-time field: the commas separate columns
    lineno, row = tokens[0]
    example = ",".join(row)
    message = (f"{example!r} looks like a number with a decimal comma, not two columns: write decimal points, "
               "or separate the columns with ';' or a tab")
    if widths != {2}:
        if 1 in widths and 2 in widths:
            raise InputDataError(message, str(path), lineno)
        return
    for lineno, row in tokens:
        if re.match(r"^0\d", row[1]):
            raise InputDataError(f"{','.join(row)!r} looks like a number with a decimal comma, not two columns: "
                                 "write decimal points, or separate the columns with ';' or a tab", str(path), lineno)
    first = [float(row[0]) for _, row in tokens]
    for k in range(1, len(first)):
        if first[k] <= first[k - 1]:
            raise InputDataError(
                f"{','.join(tokens[k][1])!r} after {','.join(tokens[k - 1][1])!r}: a first column that does not "
                "increase is no time column, so these look like numbers with a decimal comma; write decimal "
                "points, or separate the columns with ';' or a tab", str(path), tokens[k][0])


def data_lines(path: Path, layout: Layout, blanks: bool = False):
    """Yield ``(line number, tokens)`` of every data line (the slow path, used to name a bad line);
    ``blanks``: also ``(line number, [])`` for an empty line (not for a comment line)."""
    with open_binary(path, layout.compression) as raw:
        fh = io.TextIOWrapper(raw, encoding="utf-8-sig", errors="replace", newline=None)
        for lineno, text in enumerate(fh, start=1):
            if lineno < layout.first_data_line:
                continue
            try:
                line = _strip_comment(text)
            except FieldHashError as exc:
                raise InputDataError(str(exc), str(path), lineno) from None
            if not line:
                if blanks and not text.strip():
                    yield lineno, []
                continue
            tokens = _split(line, layout.delimiter)
            if layout.trailing_empty and len(tokens) > 1 and tokens[-1] == "":
                tokens = tokens[:-1]
            yield lineno, tokens


@dataclass(frozen=True)
class Scan:
    """What one pass over the data lines' bytes found: a ``#`` inside a field (``1.#QNAN``), an empty line
    among the data, and the file's last line (its text, and whether it ends with a line end)."""

    field_hash: bool
    blank_line: bool
    last_line: str
    last_has_newline: bool


def scan(path: Path, layout: Layout, chunk: int = 1 << 24) -> Scan:
    """One pass over the bytes after the header (memchr-speed searches; a regex only where a ``#`` is)."""
    field_hash = blank = False
    tail = b""
    with open_binary(path, layout.compression) as fh:
        for _ in range(max(layout.first_data_line - 1, 0)):
            if not fh.readline():
                break
        carry = b"\n"
        while True:
            block = fh.read(chunk)
            if not block:
                break
            joined = carry + block
            if not field_hash and b"#" in joined and re.search(rb"[^\s#,;]#", joined):
                field_hash = True
            if not blank:
                body = joined.rstrip(b" \t\r\n")  # empty lines at the end of the file are no gap
                blank = b"\n\n" in body or b"\n\r\n" in body or re.search(rb"\n[ \t]+\r?\n", body) is not None
            carry = joined[-2:]
            tail = (tail + block)[-4096:]
    stripped = tail.rstrip(b"\r\n")
    last = stripped.rsplit(b"\n", 1)[-1].decode("utf-8", errors="replace").strip()
    return Scan(field_hash, blank, last, tail.endswith(b"\n"))


def _fast_table(path: Path, layout: Layout, columns: list[int], time_col: int | None) -> pa.Table | None:
    """The chosen columns via pyarrow (simple delimiters) or pandas' C parser (space runs, comments);
    None when the text needs the line-by-line reader."""
    names = [f"c{i}" for i in range(layout.width + layout.trailing_empty)]
    text_cols = _text_columns(layout, time_col)
    types = {f"c{i}": (pa.string() if i in text_cols or layout.d_exponent else pa.float64()) for i in columns}
    skip = layout.first_data_line - 1
    decimal = "," if layout.decimal_comma else "."
    if layout.delimiter != " ":
        try:
            source = pa.OSFile(str(path)) if layout.compression is None else open_binary(path, layout.compression)
            with source as fh:  # pyarrow's own file for plain text: no Python in the read loop
                return pcsv.read_csv(
                    fh,
                    read_options=pcsv.ReadOptions(skip_rows=skip, column_names=names),
                    parse_options=pcsv.ParseOptions(delimiter=layout.delimiter or "\x1f"),
                    convert_options=pcsv.ConvertOptions(
                        column_types=types, include_columns=[f"c{i}" for i in columns], null_values=_NULLS,
                        strings_can_be_null=False, quoted_strings_can_be_null=False, decimal_point=decimal),
                )
        except (pa.ArrowInvalid, ValueError):
            pass
    if layout.delimiter not in (None, " ", "\t"):
        return None
    import pandas as pd  # white-space runs and "#" comments among the data

    try:
        with open_binary(path, layout.compression) as fh:
            frame = pd.read_csv(
                fh, sep=r"\s+", header=None, skiprows=skip, comment="#",
                dtype={i: (str if i in text_cols or layout.d_exponent else "float64") for i in range(layout.width)},
                decimal=decimal, engine="c", na_values=_NULLS, keep_default_na=False, skip_blank_lines=True,
                encoding="utf-8-sig",
            )
    except (ValueError, TypeError, IndexError, pd.errors.ParserError):
        return None
    if frame.shape[1] != layout.width:
        return None
    frame = frame[columns]
    frame.columns = [f"c{i}" for i in columns]
    if layout.width > 1 and frame.isna().to_numpy().any():
        return None  # pandas fills a short line with NaN: let the line reader tell a gap from a ragged line
    return pa.Table.from_pandas(frame, preserve_index=False)


def _d_text_to_float(column: pa.ChunkedArray, path: Path, layout: Layout) -> pa.ChunkedArray | None:
    """A text column of numbers with Fortran ``D`` exponents as float64; None when some text is no number
    (the line reader names its line)."""
    text = pc.utf8_trim_whitespace(column.cast(pa.string()))
    text = pc.replace_substring_regex(text, r"([\d.])[dD]([+-]?\d)", r"\1E\2")
    text = pc.if_else(pc.is_in(text, pa.array(_NULLS)), pa.scalar("nan"), text)
    try:
        return text.cast(pa.float64())
    except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
        return None


def _text_columns(layout: Layout, time_col: int | None) -> set[int]:
    """The fields read as text: the time column, and the clock-time field after a date (``pair``)."""
    if time_col is None:
        return set()
    return {time_col, time_col + 1} if layout.pair == time_col else {time_col}


def read_columns(path: Path, layout: Layout, value_col: int, time_col: int | None,
                 time_ns_per_unit: int | Fraction | None = None):
    """``(values (N,) float64, time (N,) or None, fast: bool)``; the time is a pyarrow string array, or
    integer ns (int64) when ``time_ns_per_unit`` (whole ns per unit of a numeric time column) is given and
    pyarrow takes the layout (:func:`_stream_numeric_times`).

    ``value_col`` and ``time_col`` are field indices; a time column at ``layout.pair`` is the date field
    and the clock-time field after it, joined by a space. Raises :class:`InputDataError` naming the line
    for a ragged line or text where a number belongs.
    """
    found = scan(path, layout)
    _check_last_line(path, layout, found)
    blanks_are_gaps = time_col is None and found.blank_line
    if found.field_hash or blanks_are_gaps:  # the fast readers would cut "1.#QNAN" at the "#" or drop the line
        return _line_by_line(path, layout, value_col, time_col, blanks_are_gaps)
    if (time_col is not None and time_ns_per_unit is not None and layout.pair is None and layout.delimiter != " "
            and Fraction(time_ns_per_unit).denominator == 1 and not layout.d_exponent):
        streamed = stream_numeric_times(path, layout, value_col, time_col, int(time_ns_per_unit), open_binary, _NULLS)
        if streamed is not None:
            return streamed[0], streamed[1], True
    text_cols = sorted(_text_columns(layout, time_col))
    columns = [value_col] + text_cols
    table = _fast_table(path, layout, columns, time_col)
    if table is not None and table.num_rows > 0:
        column = table.column(f"c{value_col}")
        if layout.d_exponent:  # "1.23D-09": the text with E for D, then pyarrow's exact float parse
            column = _d_text_to_float(column, path, layout)
            if column is None:
                return _line_by_line(path, layout, value_col, time_col, False)
        values = float_values(column)
        times = None
        if time_col is not None:
            times = table.column(f"c{time_col}").combine_chunks()
            if len(text_cols) == 2:
                clock = table.column(f"c{time_col + 1}").combine_chunks()
                times = pc.binary_join_element_wise(times.cast(pa.string()), clock.cast(pa.string()), " ")
        del table
        pa.default_memory_pool().release_unused()  # the parsed text's pages back to the system, not kept for reuse
        return values, times, True
    return _line_by_line(path, layout, value_col, time_col, False)


def _line_by_line(path: Path, layout: Layout, value_col: int, time_col: int | None, blanks_are_gaps: bool):
    """The slow reader of :func:`read_columns`: every line in Python, naming the line that is wrong. A Windows
    NaN spelling (``1.#QNAN``) is a missing sample, and with ``blanks_are_gaps`` so is an empty line among
    the data (both warned, with the first line and the count)."""
    text_cols = sorted(_text_columns(layout, time_col))
    values_l, times_l = [], []
    pending: list[int] = []
    blank_lines: list[int] = []
    windows: list[int] = []
    for lineno, tokens in data_lines(path, layout, blanks=blanks_are_gaps):
        if not tokens:
            pending.append(lineno)
            continue
        if pending:  # empty lines between samples: one missing sample each
            values_l.extend([np.nan] * len(pending))
            blank_lines.extend(pending)
            pending = []
        if len(tokens) != layout.width:
            raise InputDataError(f"{len(tokens)} values on this line, expected {layout.width}", str(path), lineno)
        try:
            text = tokens[value_col].replace(",", ".") if layout.decimal_comma else tokens[value_col]
            values_l.append(float(d_to_e(text)))
            if time_col is not None:
                stamp = " ".join(tokens[i] for i in text_cols)
                if not (is_date_time(stamp) or len(text_cols) == 2):
                    float(stamp)
                times_l.append(stamp)
        except ValueError:
            bad = next((t for t in tokens if not _is_number(t.replace(",", ".") if layout.decimal_comma else t)
                        and not is_date_time(t)), tokens[value_col])
            raise InputDataError(f"cannot read {bad!r} as a number", str(path), lineno) from None
    if blank_lines:
        warnings.warn(InputWarning(
            f"{path}: {len(blank_lines)} empty line{'s' if len(blank_lines) > 1 else ''} among the data (the first "
            f"at line {blank_lines[0]}) read as missing samples, so the samples after {'them' if len(blank_lines) > 1 else 'it'} keep "
            "their places"), stacklevel=3)
    windows = _windows_nan_lines(path, layout)
    if windows:
        warnings.warn(InputWarning(
            f"{path}: {len(windows)} Windows NaN spelling{'s' if len(windows) > 1 else ''} (1.#QNAN, -1.#IND; the "
            f"first at line {windows[0]}) read as missing samples"), stacklevel=3)
    times = None if time_col is None else pa.array(times_l, type=pa.string())
    return np.array(values_l, dtype=np.float64), times, False


def _windows_nan_lines(path: Path, layout: Layout) -> list[int]:
    """The line numbers holding a Windows NaN spelling (a second pass, only for a file with a '#' in a field)."""
    lines = []
    with open_binary(path, layout.compression) as raw:
        fh = io.TextIOWrapper(raw, encoding="utf-8-sig", errors="replace", newline=None)
        for lineno, text in enumerate(fh, start=1):
            if lineno >= layout.first_data_line and "#" in text and _WINDOWS_NAN_ANY.search(text):
                lines.append(lineno)
    return lines


_WINDOWS_NAN_ANY = re.compile(r"\d\.?\d*#(QNAN|SNAN|IND)", re.IGNORECASE)
#: The last line is warned as cut short when it has fewer than this fraction of the digits of the median
#: sniffed data line (or, without a line end, fewer digits than it).
TRUNCATED_DIGITS = 2 / 3


def _digits(text: str) -> int:
    mantissa = re.split(r"[eEdD]", text, maxsplit=1)[0]
    return sum(ch.isdigit() for ch in mantissa)


def _check_last_line(path: Path, layout: Layout, found: Scan) -> None:
    """Warn when the file's last line looks cut short (a write interrupted mid-number reads as a valid, wrong
    value): no line end and fewer digits than the median sniffed data line; a number of fields other than the
    lines before; a field ending mid-token (``1.5e``, ``-``, ``3.``); or a field without the exponent every
    sniffed line writes in that column and with fewer than :data:`TRUNCATED_DIGITS` of its digits (``-2.69507``
    of ``%.15e`` lines). A complete short value on an ended line (``0``, ``1e-9`` after ``%.12e`` lines) is a
    value, not a truncation."""
    last = found.last_line
    if not last or last.startswith(_COMMENT):
        return
    typical = sorted(sum(_digits(t) for t in row) for row in layout.rows)
    median = typical[len(typical) // 2] if typical else 0
    fields = _split(last, layout.delimiter)
    digits = sum(_digits(t) for t in fields)
    unended = not found.last_has_newline and digits < median
    before = [list(row) for row in layout.rows if list(row) != fields] or [list(row) for row in layout.rows]

    def width(row) -> int:  # a delimiter ending every line is no field
        return len(row) - (len(row) > 1 and row[-1] == "")

    widths = {width(row) for row in before}
    torn = len(widths) == 1 and width(fields) not in widths
    mid_token = bool(fields) and fields[-1].strip()[-1:] in ("e", "E", "d", "D", "+", "-", ".")
    lost = False
    for j, text in enumerate(fields):
        column = [row[j] for row in before if len(row) > j]
        if not column or re.search(r"[eEdD]", text) or not all(re.search(r"\d[eEdD][+-]?\d", t) for t in column):
            continue
        usual = sorted(_digits(t) for t in column)[len(column) // 2]
        lost = lost or (_digits(text) > 1 and usual >= 6 and _digits(text) < TRUNCATED_DIGITS * usual)
    short = lost or torn or mid_token
    if short or unended:
        why = f"{digits} digits where the lines before have {median}" + ("" if found.last_has_newline else ", and no line end")
        warnings.warn(InputWarning(f"{path}: the last line ({last!r}) looks cut short ({why}): an interrupted "
                                   "write? It is read as it stands"), stacklevel=4)


