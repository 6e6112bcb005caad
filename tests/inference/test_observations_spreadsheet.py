"""The generic CSV reader (inference.observations) reads a file as a spreadsheet saves it: ';' separated with decimal
commas (or points), headers ``name (unit)`` / ``name [unit]`` with blanks in the names, a byte-order mark and CRLF;
and it refuses, in one message naming the file, the line, the column and the value, a unit of other practice (with
its conversion), an unknown unit, both decimal marks in one file, a decimal comma in a ',' file and tabs."""
import numpy as np
import pytest

from inference import DataError
from inference.observations import converted, read_csv_rows, read_csv_table, split_unit

PLAIN = """# test: T1
# e0: 0.735
axial_strain_pct,q_kPa,void_ratio,time_s
0.5,40.25,0.99,6
1.0,70.5,0.98,12
2.0,-95.125,0.97,24.5
4.0,1.1e2,0.96,1e3
"""
SPREADSHEET = """# test: T1
# e0: 0.735
axial strain (%);q [kPa];void ratio;time (s)
0,5;40,25;0,99;6
1,0;70,5;0,98;12
;;;
2,0;"-95,125";0,97;24,5
4,0;1,1e2;0,96;1e3
"""


def _write(tmp_path, name, data):
    path = tmp_path / name
    path.write_bytes(data if isinstance(data, bytes) else data.encode())
    return path


@pytest.mark.parametrize("variant", [
    SPREADSHEET,
    b"\xef\xbb\xbf" + SPREADSHEET.replace("\n", "\r\n").encode(),
    PLAIN.replace(",", ";"),
    PLAIN.replace("axial_strain_pct", "axial strain [%]").replace("q_kPa", "q (kPa)"),
], ids=["semicolons, decimal commas", "with BOM and CRLF", "semicolons, decimal points", "parenthesised units"])
def test_spreadsheet_forms_read_as_the_plain_file(tmp_path, variant):
    meta, plain = read_csv_table(_write(tmp_path, "plain.csv", PLAIN))
    meta_v, table = read_csv_table(_write(tmp_path, "variant.csv", variant))
    assert meta_v == meta == {"test": "T1", "e0": "0.735"}
    assert list(table) == list(plain) == ["axial_strain", "q", "void_ratio", "time"]
    for quantity, (unit, values) in plain.items():
        assert table[quantity][0] in (unit, "%" if unit == "pct" else unit)
        assert np.array_equal(table[quantity][1], values), quantity


def test_decimal_commas_are_points_in_the_rows_and_metadata_is_as_written(tmp_path):
    text = "# e0: 0,735\n# note: a; b\nstage;time (s);q (kPa)\nshear, fast;1,5;2\n"
    meta, header, rows = read_csv_rows(_write(tmp_path, "r.csv", text))
    assert meta == {"e0": "0,735", "note": "a; b"} and header == ["stage", "time (s)", "q (kPa)"]
    assert rows == [(4, ["shear, fast", "1.5", "2"])]


@pytest.mark.parametrize("column, split", [
    ("axial strain (%)", ("axial_strain", "%")), ("q (kPa)", ("q", "kPa")), ("q [kPa]", ("q", "kPa")),
    ("  excess  pore pressure [ kPa ] ", ("excess_pore_pressure", "kPa")), ("void ratio", ("void_ratio", "-")),
    ("void ratio (-)", ("void_ratio", "-")), ("e ()", ("e", "-")), ("time_min", ("time", "min")),
    ("q_psi", ("q", "psi")), ("q (kgf/cm2)", ("q", "kgf/cm2")), ("p' (kPa)", ("p'", "kPa")),
    ("sigma_v (kN/m2)", ("sigma_v", "kN/m2")),
])
def test_column_names_and_units(column, split):
    assert split_unit(column) == split


def test_kn_per_square_metre_is_read_as_kpa(tmp_path):
    path = _write(tmp_path, "k.csv", "axial strain (%),q (kN/m2),p [kN/m²]\n0.5,40.5,100\n1,70,101\n")
    _, table = read_csv_table(path)
    assert table["q"][0] == "kN/m2" and table["p"][0] == "kN/m²"
    assert np.array_equal(converted(path, "q", *table["q"], "kPa"), [40.5, 70.0])
    assert np.array_equal(converted(path, "p", *table["p"], "kPa"), [100.0, 101.0])


@pytest.mark.parametrize("column, message", [
    ("q_psi", "unit 'psi' is not supported: convert to kPa (1 psi = 6.894757 kPa)"),
    ("q [ksi]", "unit 'ksi' is not supported: convert to MPa (1 ksi = 6.894757 MPa)"),
    ("q (psf)", "unit 'psf' is not supported: convert to kPa (1 psf = 0.04788026 kPa)"),
    ("q (ksf)", "unit 'ksf' is not supported: convert to kPa (1 ksf = 47.88026 kPa)"),
    ("q (tsf)", "unit 'tsf' is not supported: convert to kPa (1 tsf = 95.76052 kPa)"),
    ("q (kgf/cm2)", "unit 'kgf/cm2' is not supported: convert to kPa (1 kgf/cm2 = 98.0665 kPa)"),
    ("q (kg/cm²)", "unit 'kg/cm²' is not supported: convert to kPa (1 kg/cm² = 98.0665 kPa)"),
    ("q (t/m2)", "unit 't/m2' is not supported: convert to kPa (1 t/m2 = 9.80665 kPa)"),
    ("q_bar", "unit 'bar' is not supported: convert to kPa (1 bar = 100 kPa)"),
    ("q (mbar)", "unit 'mbar' is not supported: convert to kPa (1 mbar = 0.1 kPa)"),
    ("q (atm)", "unit 'atm' is not supported: convert to kPa (1 atm = 101.325 kPa)"),
    ("q (PSI)", "unit 'PSI' is not supported: convert to kPa (1 PSI = 6.894757 kPa)"),
    ("settlement_in", "unit 'in' is not supported: convert to mm (1 in = 25.4 mm)"),
    ("depth (ft)", "unit 'ft' is not supported: convert to m (1 ft = 0.3048 m)"),
    ("time (ms)", "unit 'ms' is not supported: convert to s (1 ms = 0.001 s)"),
    ("time (sec)", "unit 'sec' is not supported: write it as 's'"),
    ("time (hr)", "unit 'hr' is not supported: write it as 'h'"),
    ("time_day", "unit 'day' is not supported: write it as 'd'"),
    ("q (kpa)", "unit 'kpa' is not a known unit; did you mean 'kPa'? known: kPa, kN/m2"),
    ("q (furlong)", "unit 'furlong' is not a known unit; known: kPa, kN/m2"),
])
def test_a_unit_not_read_is_refused_with_its_conversion(tmp_path, column, message):
    path = _write(tmp_path, "u.csv", f"# a record\naxial_strain_pct,{column}\n0.5,1\n1.0,2\n")
    with pytest.raises(DataError) as err:
        read_csv_table(path)
    text = str(err.value)
    assert text.startswith(f"{path}, line 2, column {column!r}: {message}"), text
    assert "\n" not in text


def test_both_decimal_marks_in_one_file_are_refused(tmp_path):
    path = _write(tmp_path, "m.csv", "axial strain (%);q (kPa)\n0,5;40\n1;70.5\n")
    with pytest.raises(DataError) as err:
        read_csv_rows(path)
    assert str(err.value) == (f"{path}, line 3, column 'q (kPa)': value '70.5' has a decimal point, while this file "
                              "writes decimals with a comma (line 2, column 'axial strain (%)': '0,5'); use one "
                              "decimal mark in the file")


def test_a_decimal_comma_in_a_comma_file_is_refused_with_the_reason(tmp_path):
    path = _write(tmp_path, "c.csv", 'axial_strain_pct,q_kPa\n0.5,40\n1.0,"70,5"\n')
    with pytest.raises(DataError) as err:
        read_csv_table(path)
    assert str(err.value) == (f"{path}, line 3, column 'q_kPa': value '70,5' is not a finite number (a decimal "
                              "comma is read in a file separated by ';')")


def test_tabs_are_refused(tmp_path):
    path = _write(tmp_path, "t.csv", "axial_strain_pct\tq_kPa\n0.5\t40\n")
    with pytest.raises(DataError) as err:
        read_csv_rows(path)
    assert str(err.value) == (f"{path}, line 1: columns separated by tabs: 'axial_strain_pct\\tq_kPa'; separate "
                              "them by ',' or ';'")
