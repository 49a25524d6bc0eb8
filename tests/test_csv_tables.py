"""CSV tables as a CSV user means them (issue 32, items 8 and 11): a number
cell is ASCII decimal (``cdsm.files.NUMBER_CELL``) — no ``1_0``, no digits of
other scripts, no ``nan`` or ``inf`` — refused with the file, the row and the
column; today's valid files read exactly as before; and the reader streams
into columns (no per-row objects), whatever the file's size."""

from __future__ import annotations

import csv
import io
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

DATA = Path(__file__).resolve().parents[1] / "python" / "cdsm" / "data"

HEADER = "point,theta_1,theta_2,theta_3,dL_1,dL_2,dL_3,x,y\n"
ROW = "p{i},0.1,-0.2,0.05,0.001,0,0,0.21,-0.03\n"


def _table(rows: int = 3) -> list:
    return [ROW.format(i=i) for i in range(rows)]


# cells Python's float() takes (the old reader took them) and a CSV user
# does not mean as numbers
FLOAT_ONLY = ["1_0", "0.2_1", "١", "٠.٥", "\u0661\u0662", "\u2003 0.2", "0.2\u00a0", "１"]
# cells float() refuses too: refused again, with the same kind of message
NOT_NUMBERS = ["abc", "0x1p3", "1e", "+-1", "1.2.3", "1 0", "--1", "e5", "."]
NON_FINITE = ["nan", "NaN", "inf", "-inf", "Infinity", " +infinity "]


@pytest.mark.parametrize("cell", FLOAT_ONLY + NOT_NUMBERS)
def test_a_cell_that_is_not_an_ascii_number_is_refused_naming_file_row_and_column(cdsm, tmp_path, cell):
    from cdsm.calibration.measurements import read_csv

    rows = _table()
    rows[1] = rows[1].replace(",0.21,", f",{cell},")
    f = tmp_path / "m.csv"
    f.write_text(HEADER + "".join(rows), encoding="utf-8")
    with pytest.raises(cdsm.CdsmInputError) as info:
        read_csv(f, 3)
    msg = str(info.value)
    assert str(f) in msg and "row 2" in msg and "column 'x'" in msg and repr(cell) in msg
    assert "ASCII decimal" in msg


@pytest.mark.parametrize("cell", NON_FINITE + ["1e999", "-1e400"])
def test_a_non_finite_or_out_of_range_cell_is_refused(cdsm, tmp_path, cell):
    from cdsm.calibration.measurements import read_csv

    rows = _table()
    rows[2] = rows[2].replace(",0.1,", f",{cell},")
    f = tmp_path / "m.csv"
    f.write_text(HEADER + "".join(rows))
    with pytest.raises(cdsm.CdsmInputError) as info:
        read_csv(f, 3)
    msg = str(info.value)
    assert str(f) in msg and "row 3" in msg and "column 'theta_1'" in msg and repr(cell) in msg
    assert ("non-finite" in msg) if cell.strip().lstrip("+-").lower().startswith(("nan", "inf")) \
        else ("beyond the range" in msg)


@pytest.mark.parametrize("cell, value", [(" 0.5 ", 0.5), ("\t-2\t", -2.0), ("+.5", 0.5), ("5.", 5.0),
                                         ("1.e-3", 1e-3), ("1E+05", 1e5), ("-0", -0.0), ("007", 7.0),
                                         ("2.5e-310", 2.5e-310)])
def test_ascii_decimal_cells_read_as_float_reads_them(cdsm, cell, value):
    from cdsm.calibration.measurements import parse_csv

    rows = _table()
    rows[0] = rows[0].replace(",0.21,", f",{cell},")
    m = parse_csv(HEADER + "".join(rows), 3)
    assert m.measured[0, 0] == value and np.signbit(m.measured[0, 0]) == np.signbit(value)


@pytest.mark.parametrize("cell", ["1_0", "١", "nan"])
def test_targets_and_region_files_follow_the_same_rule(cdsm, tmp_path, cell):
    from cdsm.accuracy.tolerance import parse_region
    from cdsm.calibration.compensation import read_targets

    t = tmp_path / "t.csv"
    t.write_text(f"x,y\n0.2,0.0\n0.21,{cell}\n", encoding="utf-8")
    with pytest.raises(cdsm.CdsmInputError, match=r"t\.csv: row 2, column 'y'"):
        read_targets(t)
    j = tmp_path / "j.csv"
    j.write_text(f"theta_1,theta_2,theta_3\n0.1,0.2,0.3\n0.1,{cell},0.3\n", encoding="utf-8")
    with pytest.raises(cdsm.CdsmInputError, match=r"j\.csv: row 2, column 'theta_2'"):
        parse_region(f"joints:{j}", cdsm.Robot.paper())


def test_a_headerless_first_line_in_another_notation_is_refused_not_taken_for_a_header(cdsm, tmp_path):
    """A region file may have no header: its first line of numbers is data.
    A first line of numbers in another notation was read as numbers (float()
    takes them); it must not now be taken for a header and dropped."""
    from cdsm.accuracy.tolerance import parse_region

    r = cdsm.Robot.paper()
    for first in ("1_0,0.2,0.3", "\u0661,\u0662,\u0663", "0.1,nan,0.3"):
        j = tmp_path / "j.csv"
        j.write_text(f"{first}\n0.1,0.2,0.3\n", encoding="utf-8")
        with pytest.raises(cdsm.CdsmInputError, match="line 1"):
            parse_region(f"joints:{j}", r)
    j.write_text("0.1,0.2,0.3  # remark\n0.2,0.1,0.0\n")
    th, _ = parse_region(f"joints:{j}", r)
    assert th.tolist() == [[0.1, 0.2, 0.3], [0.2, 0.1, 0.0]]


@pytest.mark.parametrize("name", ["table3", "table3_theory"])
def test_the_packaged_tables_read_as_the_csv_module_and_float_read_them(cdsm, name):
    """Today's valid files read exactly as before: every cell through the
    csv module and float(), independently of the reader."""
    from cdsm.calibration.measurements import packaged

    text = (DATA / f"{name}.csv").read_text(encoding="utf-8")
    rows = list(csv.DictReader(io.StringIO("\n".join(ln for ln in text.splitlines()
                                                     if ln.strip() and not ln.startswith("#")))))
    m = packaged(name)
    col = {c: np.array([float(r[c]) for r in rows]) for c in ("x_cmd", "y_cmd", "phi_cmd", "dx", "dy")}
    np.testing.assert_array_equal(m.pose_cmd, np.stack([col["x_cmd"], col["y_cmd"], col["phi_cmd"]], 1))
    np.testing.assert_array_equal(m.measured, np.stack([col["dx"], col["dy"]], 1))
    np.testing.assert_array_equal(m.dL, np.array([[float(r[f"dL_{i}"]) for i in (1, 2, 3)] for r in rows]))
    assert m.labels == {"point": [r["point"] for r in rows]}


def test_chunks_keep_rows_labels_comments_and_unmeasured_rows(cdsm, monkeypatch):
    """Chunk boundaries change nothing: a table read three rows at a time
    (comments, blank lines, a byte-order mark, CRLF, short rows, unmeasured
    rows, labels) equals the table built by hand; a long row is refused
    with its row number in any chunk."""
    from cdsm import files
    from cdsm.calibration.measurements import parse_csv

    lines = ["\ufeff# a comment\r\n", "theta_1,theta_2,theta_3,x,y,point\r\n"]
    want_th, want_xy, labels = [], [], []
    for i in range(11):
        if i % 4 == 1:
            lines.append("   \r\n# another comment\r\n")
        th = [0.01 * i, -0.02 * i, 0.005 * i]
        xy = [0.2 + 1e-3 * i, -1e-3 * i] if i % 3 else [np.nan, np.nan]
        cells = [repr(v) for v in th] + (["", ""] if i % 3 == 0 else [repr(v) for v in xy])
        label = "" if i % 5 == 2 else f"P {i}"   # a short row: the label cell missing is empty
        lines.append(",".join(cells + ([label] if label else [])) + "\r\n")
        want_th.append(th)
        want_xy.append(xy)
        labels.append(label)
    text = "".join(lines)
    monkeypatch.setattr(files, "CHUNK_ROWS", 3)
    m = parse_csv(text, 3)
    assert len(m) == 11 and m.labels == {"point": labels}
    np.testing.assert_array_equal(m.theta, np.array(want_th))
    np.testing.assert_array_equal(m.measured, np.array(want_xy))
    np.testing.assert_array_equal(m.dL, np.zeros((11, 3)))
    with pytest.raises(cdsm.CdsmInputError, match="row 9: more values than the 6 columns"):
        parse_csv(text.replace("P 8", "P 8,extra"), 3)
    with pytest.raises(cdsm.CdsmInputError, match="row 10, column 'theta_2': not a number: '1_0'"):
        parse_csv(text.replace(repr(-0.02 * 9), "1_0"), 3)


def test_the_reader_holds_columns_not_rows(cdsm, tmp_path):
    """Memory bounded by design: reading a 50 000-row file (9 numeric
    columns, 8 MB) peaks (Python allocations, tracemalloc) at a few chunks'
    worth above its arrays (3.6 MB); the reader that kept a dict of strings
    per row and the whole text peaked above 80 MB."""
    from cdsm.calibration.measurements import read_csv

    rng = np.random.default_rng(0)
    vals = rng.uniform(-0.4, 0.4, (50_000, 8))
    f = tmp_path / "big.csv"
    with open(f, "w") as fh:
        fh.write("theta_1,theta_2,theta_3,dL_1,dL_2,dL_3,x,y\n")
        for r in vals:
            fh.write(",".join(repr(float(v)) for v in r) + "\n")
    tracemalloc.start()
    try:
        m = read_csv(f, 3)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert len(m) == 50_000 and np.array_equal(m.measured, vals[:, 6:])
    assert peak < 30 * 2 ** 20, f"peak {peak / 2 ** 20:.1f} MB"
