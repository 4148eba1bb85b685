"""Columns of text to numbers, fast and exact: float64 values from pyarrow's chunks, decimal time tags to
integer nanoseconds, and the batch-by-batch read of a numeric time column.

Used by :mod:`chronofuse.io.columns` (which re-exports :func:`decimal_text_to_ns`); kept apart because it
is the reading machinery, not the layout: nothing here decides what a file holds.
"""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pcsv

__all__ = ["float_values", "decimal_text_to_ns", "stream_numeric_times", "FRACTION_DIGITS"]

# Fraction digits kept exactly: 10**17 * 27 (days: ns_per_unit / 10**17 = 27/31250) still fits an int64.
FRACTION_DIGITS = 17


def float_values(column: pa.ChunkedArray) -> np.ndarray:
    """A float64 column as one writable numpy array (N,), nulls as NaN.

    Each chunk's values are viewed in place (``np.frombuffer``, no copy) and the views joined by one
    ``np.concatenate``: a single copy, in a single call. Copying chunk by chunk into the result took
    the GIL back for each chunk (221 of them at 1e7 values), and while the stability engine loads on
    another thread each of those waited for it (the read took 0.9-1.3 s that way, against 0.5 s alone);
    pyarrow's ``combine_chunks`` followed by a copy to make the result writable copies twice (3.5 s of
    a 7 s read at 1e8 values). pyarrow's own ``to_numpy`` of a chunked column goes through its pandas
    conversion, which imports pandas (about 0.4 s of start-up) and copies twice.
    """
    if column.null_count:
        column = pc.fill_null(column, np.nan)
    views = [np.frombuffer(chunk.buffers()[1], dtype=np.float64, count=len(chunk), offset=chunk.offset * 8)
             for chunk in column.chunks if len(chunk)]
    if not views:
        return np.empty(0, dtype=np.float64)
    return np.concatenate(views) if len(views) > 1 else views[0].copy()


def stream_numeric_times(path: Path, layout, value_col: int, time_col: int, ns_per_unit: int, opener,
                         nulls: list[str]) -> tuple[np.ndarray, np.ndarray] | None:
    """Values (N,) float64 and time tags (N,) int64 ns read batch by batch with pyarrow's streaming CSV
    reader, each batch's time text parsed at once by :func:`~chronofuse.io.kernels_time.parse_decimal_ns`
    and dropped: the text of the whole column is never held (at 1e8 tags it is 2 GB). None when pyarrow
    cannot take the layout or a tag is not a plain decimal number (the caller's slower path names it).
    ``layout`` is a :class:`chronofuse.io.columns.Layout`, ``opener(path, compression)`` opens the file's
    decompressed bytes, ``nulls`` the texts read as NaN."""
    from chronofuse.io.kernels_time import FRACTION_DIGITS, parse_decimal_ns

    ratio = Fraction(ns_per_unit) / 10**FRACTION_DIGITS
    names = [f"c{i}" for i in range(layout.width + layout.trailing_empty)]
    types = {f"c{value_col}": pa.float64(), f"c{time_col}": pa.string()}
    values, times = [], []
    read_options = pcsv.ReadOptions(skip_rows=layout.first_data_line - 1, column_names=names, block_size=1 << 24)
    parse_options = pcsv.ParseOptions(delimiter=layout.delimiter or "\x1f")
    convert_options = pcsv.ConvertOptions(
        column_types=types, include_columns=[f"c{value_col}", f"c{time_col}"], null_values=nulls,
        strings_can_be_null=False, quoted_strings_can_be_null=False, decimal_point="," if layout.decimal_comma else ".")

    def take(value_chunk: pa.Array, text: pa.Array) -> bool:
        if text.null_count:
            return False
        if len(text) == 0:
            return True
        buffers = text.buffers()
        offsets = np.frombuffer(buffers[1], dtype=np.int32 if pa.types.is_string(text.type) else np.int64)
        data = np.frombuffer(buffers[2], dtype=np.uint8) if buffers[2] is not None else np.zeros(0, np.uint8)
        out = np.empty(len(text), dtype=np.int64)
        if parse_decimal_ns(data, offsets, text.offset, len(text), int(ns_per_unit), ratio.numerator,
                            ratio.denominator, out) >= 0:
            return False
        times.append(out)
        values.append(float_values(pa.chunked_array([value_chunk])))
        return True

    try:
        # A plain file under 1.5 GB is parsed at once on every core; larger or compressed ones batch by batch,
        # so that the column's text (2 GB at 1e8 tags) is never held whole.
        whole = layout.compression is None and path.stat().st_size < 1_500_000_000
        if whole:
            table = pcsv.read_csv(str(path), read_options=read_options, parse_options=parse_options,
                                  convert_options=convert_options)
            for value_chunk, text in zip(table.column(f"c{value_col}").chunks, table.column(f"c{time_col}").chunks):
                if not take(value_chunk, text):
                    return None
            del table
        else:
            source = pa.OSFile(str(path)) if layout.compression is None else opener(path, layout.compression)
            with source as fh, pcsv.open_csv(fh, read_options=read_options, parse_options=parse_options,
                                             convert_options=convert_options) as reader:
                for batch in reader:
                    if not take(batch.column(f"c{value_col}"), batch.column(f"c{time_col}")):
                        return None
    except (pa.ArrowInvalid, ValueError):
        return None
    if not values:
        return None
    joined = np.concatenate(values) if len(values) > 1 else values[0]
    del values
    stamps = np.concatenate(times) if len(times) > 1 else times[0]
    pa.default_memory_pool().release_unused()
    return joined, stamps


def decimal_text_to_ns(text: pa.Array, ns_per_unit: int | Fraction) -> tuple[np.ndarray, int]:
    """Exact integer nanoseconds of decimal numbers written as text, shape (N,).

    Integer and fraction parts are converted separately (no float64 on the way: at today's MJD a float64
    of seconds steps by ~1 us, of days by ~0.6 us), the fraction to 17 digits and rounded to the ns:
    ``ns = int_part * ns_per_unit + round(frac_17_digits * ns_per_unit / 10**17)``, exact for up to 17
    fraction digits (beyond them, under 1e-3 ns even for days). Numbers with an
    exponent (``1.7e9``) are converted through :class:`fractions.Fraction`, also exactly. Returns
    ``(ns, bad)`` where ``bad`` is the index of the first text that is not a decimal number (-1 if none).
    """
    ratio = Fraction(ns_per_unit) / 10**FRACTION_DIGITS
    s = pc.utf8_trim_whitespace(pc.cast(text, pa.string()))
    plain = pc.match_substring_regex(s, r"^[+-]?(\d+\.?\d*|\.\d+)$")
    if not pc.all(plain).as_py():
        ok = plain.to_numpy(zero_copy_only=False)
        out = np.zeros(len(s), dtype=np.int64)
        for k in np.flatnonzero(~ok):
            try:
                value = Fraction(s[k].as_py()) * Fraction(ns_per_unit)
            except (ValueError, ZeroDivisionError):
                return out, int(k)
            out[k] = round(value)
        if ok.any():
            out[ok] = decimal_text_to_ns(pc.filter(s, plain), ns_per_unit)[0]
        return out, -1
    negative = pc.starts_with(s, "-").to_numpy(zero_copy_only=False)
    s = pc.replace_substring_regex(s, r"^[+-]", "")
    s = pc.if_else(pc.match_substring(s, "."), s, pc.binary_join_element_wise(s, "", "."))
    parts = pc.split_pattern(s, ".", max_splits=1)
    whole = pc.list_element(parts, 0)
    whole = pc.if_else(pc.equal(whole, ""), "0", whole)
    frac = pc.utf8_slice_codeunits(pc.utf8_rpad(pc.list_element(parts, 1), FRACTION_DIGITS, "0"), 0,
                                   FRACTION_DIGITS)
    whole_i = pc.cast(whole, pa.int64()).to_numpy()
    frac_i = pc.cast(frac, pa.int64()).to_numpy()
    p, q = ratio.numerator, ratio.denominator
    per = int(Fraction(ns_per_unit))
    if whole_i.size and int(np.abs(whole_i).max()) > (2**63 - 1) // max(per, 1) - 1:
        raise OverflowError(f"a time of {int(np.abs(whole_i).max())} units does not fit in int64 nanoseconds")
    ns = whole_i * per + (frac_i * p + q // 2) // q
    return np.where(negative, -ns, ns), -1
