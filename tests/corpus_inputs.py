"""The corpus of bad inputs replayed by tests/cases/test_input_corpus.py, and the valid inputs they are variants of.

Each bad case is (name, input, [parts the one-line error must hold]): recording CSVs (text or bytes) of a laboratory
study and of a pressuremeter record, edits of a study file, command-line options of cases.calibrate and
cases.burswood_sbp. The valid variants (line ends, byte-order mark, quoting, bracket units, MPa) must load to the
same values as the plain file.
"""

LAB_CSV = """# a small drained test
axial_strain_pct,q_kPa,void_ratio
0.5,40,0.99
1.0,70,0.98
2.0,95,0.97
4.0,110,0.96
"""
LAB_TOML = """name = "mini"

[model]
name = "ModifiedCamClay"

[model.fixed]
lambda_ = 0.2
kappa = 0.04
nu = 0.3

[model.free]
M = [0.8, 1.8]
ocr = { bounds = [1.0, 4.0], prior = "log-uniform" }

[sigma_eps]
bounds = [0.001, 0.3]

[[tests]]
name = "T1"
file = "t1.csv"
type = "triaxial"
drainage = "drained"
direction = "compression"
consolidation = "isotropic"
p0 = 100.0
e0 = 1.0
strain_rate = 1e-5
"""
PROGRAMME_TOML = LAB_TOML[: LAB_TOML.index("[[tests]]")] + """[[tests]]
name = "CID_1"
file = "t1.csv"
apparatus = "triaxial"
initial = { e0 = 1.0, p0 = 100.0 }
stages = [{ kind = "shear", drainage = "drained", strain_rate = 1e-5 }]
"""
SBP_CSV = """# a pressuremeter record
cavity_strain_pct,cavity_pressure_kPa,pore_pressure_kPa,time_s
1.0,100,40,6
2.0,120,42,12
4.0,140,45,24
"""


def rows(*rows, header="axial_strain_pct,q_kPa,void_ratio"):
    return header + "\n" + "\n".join(rows) + "\n"


LAB_CSVS = [
    ("latin-1", "# essai à 20 °C\n".encode("latin-1") + LAB_CSV.encode(), ["not UTF-8", "Latin-1", "line 1"]),
    ("utf-16", LAB_CSV.encode("utf-16"), ["not UTF-8", "UTF-16"]),
    ("binary", b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\x00\x00", ["not UTF-8", "binary"]),
    ("binary-no-nul", bytes(range(128, 256)) * 4, ["not UTF-8"]),
    ("empty", "", ["no header or no data rows"]),
    ("comments only", "# nothing here\n# really\n", ["no header or no data rows"]),
    ("header only", "axial_strain_pct,q_kPa\n", ["no header or no data rows"]),
    ("same column twice", rows("0.5,40,40", "1,70,70", header="axial_strain_pct,q_kPa,q_kPa"),
     ["'q_kPa' appears twice"]),
    ("q in kPa and MPa", rows("0.5,40,0.04", "1,70,0.07", header="axial_strain_pct,q_kPa,q_MPa"),
     ["'q_kPa' and 'q_MPa'", "same quantity 'q'"]),
    ("q suffix and bracket", rows("0.5,40,0.04", "1,70,0.07", header="axial_strain_pct,q_kPa,q [MPa]"),
     ["'q_kPa' and 'q [MPa]'"]),
    ("strain twice", rows("0.5,0.5,40", "1,1,70", header="axial_strain_pct,axial_strain [%],q_kPa"),
     ["same quantity 'axial_strain'"]),
    ("unnamed column", rows("0.5,40,1", "1,70,2", header="axial_strain_pct,q_kPa,"), ["column 3", "no name"]),
    ("semicolons, both decimal marks", "axial_strain_pct;q_kPa\n0,5;40\n1.0;70\n",
     ["line 3", "'axial_strain_pct'", "'1.0'", "decimal point", "line 2", "'0,5'"]),
    ("decimal comma in a comma file", rows('0.5,40,0.99', '1.0,"70,5",0.98'),
     ["line 3", "'q_kPa'", "'70,5'", "decimal comma is read in a file separated by ';'"]),
    ("unit psi suffix", rows("0.5,5.8", "1.0,10.2", header="axial_strain_pct,q_psi"),
     ["line 1", "'q_psi'", "unit 'psi' is not supported: convert to kPa (1 psi = 6.894757 kPa)"]),
    ("unit kgf/cm2", rows("0.5,0.4", "1.0,0.7", header="axial strain (%),q (kgf/cm2)"),
     ["'q (kgf/cm2)'", "unit 'kgf/cm2' is not supported: convert to kPa (1 kgf/cm2 = 98.0665 kPa)"]),
    ("unit ksf", rows("0.5,0.8", "1.0,1.5", header="axial_strain_pct,q (ksf)"),
     ["'q (ksf)'", "unit 'ksf' is not supported: convert to kPa (1 ksf = 47.88026 kPa)"]),
    ("unit tsf suffix", rows("0.5,0.4", "1.0,0.7", header="axial_strain_pct,q_tsf"),
     ["'q_tsf'", "unit 'tsf' is not supported: convert to kPa (1 tsf = 95.76052 kPa)"]),
    ("unit hr", rows("0.5,40,1", "1.0,70,2", header="axial_strain_pct,q_kPa,time [hr]"),
     ["'time [hr]'", "unit 'hr' is not supported: write it as 'h'"]),
    ("unit in inches", rows("0.5,40,0.1", "1.0,70,0.2", header="axial_strain_pct,q_kPa,displacement [in]"),
     ["'displacement [in]'", "unit 'in' is not supported: convert to mm (1 in = 25.4 mm)"]),
    ("unit kpa", rows("0.5,40", "1.0,70", header="axial_strain_pct,q (kpa)"),
     ["'q (kpa)'", "unit 'kpa' is not a known unit; did you mean 'kPa'?"]),
    ("unit day", rows("0.5,40,1", "1.0,70,2", header="axial_strain_pct,q_kPa,time (day)"),
     ["'time (day)'", "unit 'day' is not supported: write it as 'd'"]),
    ("tabs", "axial_strain_pct\tq_kPa\n0.5\t40\n1.0\t70\n", ["line 1", "separated by tabs", "',' or ';'"]),
    ("short row", rows("0.5,40,0.99", "1.0,70"), ["line 3", "2 values for 3 columns"]),
    ("long row", rows("0.5,40,0.99", "1.0,70,0.98,5"), ["line 3", "4 values for 3 columns"]),
    ("text value", rows("0.5,40,0.99", "1.0,abc,0.98"), ["line 3", "'q_kPa'", "'abc'"]),
    ("empty cell", rows("0.5,40,0.99", "1.0,,0.98"), ["line 3", "'q_kPa'", "''"]),
    ("nan", rows("0.5,40,0.99", "1.0,nan,0.98"), ["line 3", "'nan'", "not a finite number"]),
    ("inf", rows("0.5,40,0.99", "1.0,inf,0.98"), ["line 3", "'inf'"]),
    ("minus inf", rows("0.5,40,0.99", "1.0,-inf,0.98"), ["line 3", "'-inf'"]),
    ("decimal comma", rows('0.5,40,0.99', '"1,0",70,0.98'), ["line 3", "'1,0'"]),
    ("q 1e308", rows("0.5,40,0.99", "1.0,1e308,0.98"), ["line 3", "'q' in kPa", "1e308", "physical range"]),
    ("q 2e6 kPa", rows("0.5,40,0.99", "1.0,2e6,0.98"), ["line 3", "2e6", "1e6 kPa"]),
    ("q 5000 MPa", rows("0.5,0.04,0.99", "1.0,5000,0.98", header="axial_strain_pct,q [MPa],void_ratio"),
     ["line 3", "'q' in MPa", "5000"]),
    ("strain 140 %", rows("0.5,40,0.99", "140,70,0.98"), ["line 3", "'axial_strain' in pct", "140"]),
    ("strain -200 %", rows("-200,40,0.99", "1,70,0.98"), ["line 2", "-200"]),
    ("negative strain", rows("-0.5,40,0.99", "1.0,70,0.98"), ["line 2", "'axial_strain'", "-0.5"]),
    ("strain goes back", rows("0.5,40,0.99", "0.4,70,0.98"), ["line 3", "0.4", "does not increase"]),
    ("strain repeated", rows("0.5,40,0.99", "0.5,70,0.98"), ["line 3", "does not increase"]),
    ("void ratio negative", rows("0.5,40,0.99", "1.0,70,-0.98"), ["line 3", "'void_ratio'", "-0.98"]),
    ("void ratio zero", rows("0.5,40,0.99", "1.0,70,0"), ["line 3", "'void_ratio'", "must be > 0"]),
    ("time negative", rows("0.5,40,0.99,-5", "1.0,70,0.98,10", header="axial_strain_pct,q_kPa,void_ratio,time_s"),
     ["line 2", "'time' in s", "-5"]),
    ("time goes back", rows("0.5,40,0.99,20", "1.0,70,0.98,10", header="axial_strain_pct,q_kPa,void_ratio,time_s"),
     ["line 3", "'time'", "10"]),
    ("unknown column", rows("0.5,40,1", "1,70,2", header="axial_strain_pct,q_kPa,deviator_kPa"),
     ["column 'deviator'", "known:"]),
    ("typo q_kpa", rows("0.5,40", "1,70", header="axial_strain_pct,q_kpa"), ["'q_kpa'", "did you mean 'q_kPa'"]),
    ("typo void_ration", rows("0.5,40,0.99", "1,70,0.98", header="axial_strain_pct,q_kPa,void_ration"),
     ["'void_ration'", "did you mean 'void_ratio'"]),
    ("typo volumetric", rows("0.5,40,0.1", "1,70,0.2", header="axial_strain_pct,q_kPa,volumetric_strian_pct"),
     ["did you mean 'volumetric_strain_pct'"]),
    ("typo time", rows("0.5,40,1", "1,70,2", header="axial_strain_pct,q_kPa,tim_s"), ["did you mean 'time_s'"]),
    ("upper case", rows("0.5,40", "1,70", header="AXIAL_STRAIN_PCT,q_kPa"), ["did you mean 'axial_strain_pct'"]),
    ("strain without unit", rows("0.005,40", "0.01,70", header="axial_strain,q_kPa"),
     ["'axial_strain'", "unit '-'", "expected '%'"]),
    ("unit psi", rows("0.5,4", "1,7", header="axial_strain_pct,q [psi]"),
     ["column 'q [psi]'", "unit 'psi' is not supported"]),
    ("stress in seconds", rows("0.5,40", "1,70", header="axial_strain_pct,q_s"), ["column 'q'", "unit 's'"]),
    ("pore pressure in a drained test", rows("0.5,40,5", "1,70,6", header="axial_strain_pct,q_kPa,"
                                              "excess_pore_pressure_kPa"), ["'excess_pore_pressure'", "drained"]),
    ("missing q", rows("0.5,0.99", "1,0.98", header="axial_strain_pct,void_ratio"), ["missing column 'q'"]),
    ("missing strain", rows("40,0.99", "70,0.98", header="q_kPa,void_ratio"), ["missing column 'axial_strain'"]),
    ("numbers as header", rows("0.5,40", "1,70", header="0.1,20"), ["column '0.1'"]),
    ("volumetric 150 %", rows("0.5,40,0.1", "1,70,150", header="axial_strain_pct,q_kPa,volumetric_strain_pct"),
     ["line 3", "150"]),
    ("quoted text", rows('0.5,40,0.99', '1.0,"12a",0.98'), ["line 3", "'12a'"]),
    ("p zero", rows("0.5,40,0", "1,70,100", header="axial_strain_pct,q_kPa,p_kPa"), ["line 2", "'p'", "> 0"]),
]

#: bad records of a stage programme (the same CSV conventions, read by cases.study.reading.stage_records)
PROGRAMME_CSVS = [
    ("unit psi", rows("0.5,5.8", "1.0,10.2", header="axial_strain_pct,q_psi"),
     ["line 1", "'q_psi'", "unit 'psi' is not supported: convert to kPa (1 psi = 6.894757 kPa)"]),
    ("unit ksf", rows("0.5,0.8", "1.0,1.5", header="axial strain (%),q (ksf)"),
     ["'q (ksf)'", "unit 'ksf' is not supported: convert to kPa (1 ksf = 47.88026 kPa)"]),
    ("typo void_ration", rows("0.5,40,0.99", "1,70,0.98", header="axial_strain_pct,q_kPa,void_ration"),
     ["column 'void_ration' is not a column of an triaxial programme; did you mean 'void_ratio'?"]),
    ("typo stage", rows("1,0.5,40", "1,1,70", header="stgae,axial_strain_pct,q_kPa"),
     ["column 'stgae'", "did you mean 'stage'?"]),
]


def sbp_rows(*rows, header="cavity_strain_pct,cavity_pressure_kPa,pore_pressure_kPa"):
    return header + "\n" + "\n".join(rows) + "\n"


SBP_CSVS = [
    ("latin-1", "# pression mesurée\n".encode("latin-1") + SBP_CSV.encode(), ["not UTF-8", "Latin-1"]),
    ("utf-16", SBP_CSV.encode("utf-16"), ["UTF-16"]),
    ("binary", bytes(range(256)), ["not UTF-8", "binary"]),
    ("empty", "", ["no header or no data rows"]),
    ("cavity pressure twice", sbp_rows("1,100,100", "2,120,120",
                                   header="cavity_strain_pct,cavity_pressure_kPa,cavity_pressure_kPa"),
     ["'cavity_pressure_kPa' appears twice"]),
    ("pressure in kPa and MPa", sbp_rows("1,100,0.1", "2,120,0.12",
                                     header="cavity_strain_pct,cavity_pressure_kPa,cavity_pressure [MPa]"),
     ["same quantity 'cavity_pressure'"]),
    ("typo pore pressure", sbp_rows("1,100,40", "2,120,42",
                                header="cavity_strain_pct,cavity_pressure_kPa,pore_presure_kPa"),
     ["'pore_presure'", "did you mean 'pore_pressure_kPa'"]),
    ("typo pore unit", sbp_rows("1,100,40", "2,120,42",
                                header="cavity_strain_pct,cavity_pressure_kPa,pore_pressure_kpa"),
     ["did you mean 'pore_pressure_kPa'"]),
    ("typo cavity pressure", sbp_rows("1,100", "2,120", header="cavity_strain_pct,cavity_presure_kPa"),
     ["did you mean 'cavity_pressure_kPa'"]),
    ("unknown u", sbp_rows("1,100,40", "2,120,42", header="cavity_strain_pct,cavity_pressure_kPa,u_kPa"),
     ["column 'u'", "known:"]),
    ("strain 15 %", sbp_rows("1,100,40", "15,120,42"), ["line 3", "'cavity_strain'", "15", "10 %"]),
    ("strain negative", sbp_rows("-1,100,40", "2,120,42"), ["line 2", "-1"]),
    ("strain goes back", sbp_rows("2,100,40", "1,120,42"), ["line 3", "does not increase"]),
    ("pressure negative", sbp_rows("1,100,40", "2,-120,42"), ["line 3", "'cavity_pressure'", "-120"]),
    ("pressure 1e308", sbp_rows("1,100,40", "2,1e308,42"), ["line 3", "1e308", "physical range"]),
    ("pore pressure 5e6", sbp_rows("1,100,40", "2,120,5e6"), ["line 3", "'pore_pressure' in kPa", "5e6"]),
    ("nan", sbp_rows("1,100,40", "2,NaN,42"), ["line 3", "'NaN'"]),
    ("text", sbp_rows("1,100,40", "2,high,42"), ["line 3", "'high'"]),
    ("missing pressure", sbp_rows("1,40", "2,42", header="cavity_strain_pct,pore_pressure_kPa"),
     ["missing column 'cavity_pressure'"]),
    ("strain without unit", sbp_rows("0.01,100", "0.02,120", header="cavity_strain,cavity_pressure_kPa"),
     ["'cavity_strain'", "unit '-'"]),
    ("unit psi", sbp_rows("1,14", "2,17", header="cavity_strain_pct,cavity_pressure [psi]"),
     ["line 1", "'cavity_pressure [psi]'", "unit 'psi' is not supported: convert to kPa (1 psi = 6.894757 kPa)"]),
    ("unit bar", sbp_rows("1;1,4", "2;1,7", header="cavity strain (%);cavity pressure (bar)"),
     ["'cavity pressure (bar)'", "unit 'bar' is not supported: convert to kPa (1 bar = 100 kPa)"]),
    ("row length", sbp_rows("1,100,40", "2,120"), ["line 3", "2 values for 3 columns"]),
    ("semicolons, both decimal marks", "cavity_strain_pct;cavity_pressure_kPa\n1,5;100\n2;120.5\n",
     ["line 3", "'cavity_pressure_kPa'", "'120.5'", "decimal point", "'1,5'"]),
    ("time negative", sbp_rows("1,100,-6", "2,120,12", header="cavity_strain_pct,cavity_pressure_kPa,time_s"),
     ["line 2", "'time' in s", "-6"]),
]


def edit(old, new):
    def edit(text):
        assert old in text, old
        return text.replace(old, new)
    return edit


LAB_TOMLS = [
    ("not toml", lambda t: "[model\nname = 1", ["not valid TOML"]),
    ("latin-1 toml", lambda t: ("# étude\n" + t).encode("latin-1"), ["line 1", "not UTF-8"]),
    ("binary toml", lambda t: b"\x00\x01\x02\xff\xfe", ["not UTF-8"]),
    ("no model", lambda t: t.replace("[model]\nname", "[modle]\nname"), ["modle", "unknown field"]),
    ("unknown model", edit('name = "ModifiedCamClay"', 'name = "CamClay"'), ["model.name", "'CamClay'"]),
    ("model name a number", edit('name = "ModifiedCamClay"', "name = 3"), ["model.name", "3"]),
    ("empty free", lambda t: t.replace('M = [0.8, 1.8]\nocr = { bounds = [1.0, 4.0], prior = "log-uniform" }\n',
                                       "M = 1.2\nocr = 2.0\n").replace("[model.free]\n", "[model.free]\n[x]\n"),
     ["x", "unknown field"]),
    ("bounds reversed", edit("M = [0.8, 1.8]", "M = [1.8, 0.8]"), ["model.free.M", "[1.8, 0.8]"]),
    ("bounds text", edit("M = [0.8, 1.8]", 'M = ["low", 1.8]'), ["model.free.M", "low"]),
    ("bounds nan", edit("M = [0.8, 1.8]", "M = [nan, 1.8]"), ["model.free.M", "nan"]),
    ("bounds inf", edit("M = [0.8, 1.8]", "M = [0.8, inf]"), ["model.free.M", "inf"]),
    ("bounds three", edit("M = [0.8, 1.8]", "M = [0.8, 1.2, 1.8]"), ["model.free.M", "[0.8, 1.2, 1.8]"]),
    ("log-uniform from 0", edit("bounds = [1.0, 4.0]", "bounds = [0.0, 4.0]"), ["model.free.ocr.bounds"]),
    ("prior normal", edit('prior = "log-uniform"', 'prior = "normal"'), ["model.free.ocr.prior", "'normal'"]),
    ("nu 0.6", edit("nu = 0.3", "nu = 0.6"), ["[model.fixed]", "0.6"]),
    ("lambda below kappa", edit("lambda_ = 0.2", "lambda_ = 0.03"), ["kappa", "lambda_"]),
    ("fixed text", edit("nu = 0.3", 'nu = "0.3"'), ["model.fixed.nu", "'0.3'"]),
    ("unknown parameter", edit("M = [0.8, 1.8]", "M = [0.8, 1.8]\nphi = [20, 40]"), ["model.free.phi"]),
    ("fixed and free", edit("nu = 0.3\n", "nu = 0.3\nM = 1.2\n"), ["model.free.M"]),
    ("sigma_eps negative", edit("bounds = [0.001, 0.3]", "bounds = [-0.1, 0.3]"), ["sigma_eps.bounds", "-0.1"]),
    ("sigma_eps in model", edit("M = [0.8, 1.8]", "M = [0.8, 1.8]\nsigma_eps = [0.01, 0.2]"),
     ["model.free.sigma_eps"]),
    ("samples 2", edit("[sigma_eps]", "[sampler]\nsamples = 2\n\n[sigma_eps]"), ["sampler.samples", "2"]),
    ("samples text", edit("[sigma_eps]", '[sampler]\nsamples = "many"\n\n[sigma_eps]'), ["sampler.samples", "many"]),
    ("max_steps 0", edit("[sigma_eps]", "[sampler.quick]\nmax_steps = 0\n\n[sigma_eps]"),
     ["sampler.quick.max_steps", "0"]),
    ("radial cells 0", edit("[sigma_eps]", "[fe]\nradial_cells = 0\n\n[sigma_eps]"), ["fe.radial_cells", "0"]),
    ("increments -5", edit("[sigma_eps]", "[fe]\nincrements = -5\n\n[sigma_eps]"), ["fe.increments", "-5"]),
    ("layers 1.5", edit("[sigma_eps]", "[fe]\nlayers = 1.5\n\n[sigma_eps]"), ["fe.layers", "1.5"]),
    ("outer open", edit("[sigma_eps]", '[fe]\nouter = "open"\n\n[sigma_eps]'), ["fe.outer", "'open'"]),
    ("quick outer radius 0.5", edit("[sigma_eps]", "[fe.quick]\nouter_radius_a0 = 0.5\n\n[sigma_eps]"),
     ["fe.quick.outer_radius_a0", "0.5", "outside the probe"]),
    ("outer radius 1", edit("[sigma_eps]", "[fe]\nouter_radius_a0 = 1\n\n[sigma_eps]"),
     ["fe.outer_radius_a0", "1"]),
    ("fe unknown field", edit("[sigma_eps]", "[fe]\ncells = 10\n\n[sigma_eps]"), ["fe.cells"]),
    ("no tests", lambda t: "tests = []\n" + t[: t.index("[[tests]]")], ["tests = []"]),
    ("unknown type", edit('type = "triaxial"', 'type = "triax"'), ["tests['T1'].type", "'triax'"]),
    ("missing file", edit('file = "t1.csv"', 'file = "nope.csv"'), ["tests['T1'].file", "'nope.csv'"]),
    ("file is a folder", edit('file = "t1.csv"', 'file = "."'), ["tests['T1'].file", "'.'"]),
    ("strain rate 0", edit("strain_rate = 1e-5", "strain_rate = 0.0"), ["tests['T1'].strain_rate", "0.0"]),
    ("strain rate negative", edit("strain_rate = 1e-5", "strain_rate = -1e-5"), ["tests['T1'].strain_rate", "-1e-05"]),
    ("p0 zero", edit("p0 = 100.0", "p0 = 0.0"), ["tests['T1'].p0", "0.0"]),
    ("p0 negative", edit("p0 = 100.0", "p0 = -100.0"), ["tests['T1'].p0", "-100.0"]),
    ("field typo", edit("strain_rate = 1e-5", "straln_rate = 1e-5"),
     ["tests['T1'].straln_rate = 1e-05: unknown field; did you mean 'strain_rate'?"]),
    ("choice typo", edit('drainage = "drained"', 'drainage = "drianed"'),
     ["tests['T1'].drainage = 'drianed': did you mean 'drained'? expected one of drained, undrained"]),
    ("table typo", lambda t: t.replace("[sigma_eps]", "[sigma_esp]"), ["sigma_esp", "did you mean 'sigma_eps'?"]),
    ("parameter typo", edit("kappa = 0.04", "kapa = 0.04"),
     ["model.fixed.kapa = 0.04: unknown parameter of ModifiedCamClay; did you mean 'kappa'?"]),
    ("drainage", edit('drainage = "drained"', 'drainage = "partly"'), ["tests['T1'].drainage", "'partly'"]),
    ("same test name", lambda t: t + t[t.index("[[tests]]"):], ["tests['T1'].name", "'T1'"]),
    ("e0 missing", edit("e0 = 1.0\n", ""), ["tests['T1'].e0", "missing"]),
    ("K0 with isotropic", edit("p0 = 100.0", "p0 = 100.0\nK0 = 0.5"), ["tests['T1'].K0", "0.5"]),
    ("curves", edit("strain_rate = 1e-5", 'strain_rate = 1e-5\ncurves = ["q", "u"]'), ["tests['T1'].curves"]),
    ("synthetic field", lambda t: t + "\n[synthetic]\nnoize = 0.1\n", ["synthetic.noize"]),
    ("enrichment typo", lambda t: t + "\n[enrichment.viscosty]\nC_alpha_e = [0.001, 0.05]\n",
     ["enrichment.viscosty = {'C_alpha_e': [0.001, 0.05]}: not a candidate of the catalog; did you mean "
      "'viscosity'? candidates with parameters: viscosity, time_dependent_swelling, partial_drainage, "
      "anisotropy, destructuration"]),
    ("enrichment parameter typo", lambda t: t + "\n[enrichment.viscosity]\nC_alpha = [0.001, 0.05]\n",
     ["enrichment.viscosity.C_alpha = [0.001, 0.05]: not a parameter of the 'viscosity' enrichment; did you mean "
      "'C_alpha_e'? it adds C_alpha_e"]),
    ("enrichment log-uniform from 0", lambda t: t + "\n[enrichment.viscosity]\nC_alpha_e = [0.0, 0.05]\n",
     ["enrichment.viscosity.C_alpha_e = [0.0, 0.05]: a log-uniform prior needs a lower bound > 0"]),
    ("enrichment bounds reversed", lambda t: t + '\n[enrichment."time-dependent swelling"]\ntau_s = [1e6, 1e3]\n',
     ["enrichment.time-dependent swelling.tau_s = [1000000.0, 1000.0]: lower bound must be < upper bound"]),
    ("enrichment below the physical range", lambda t: t + "\n[enrichment.destructuration]\n"
     'chi0 = { bounds = [-1.0, 20.0], prior = "uniform" }\n', ["enrichment.destructuration.chi0", "chi0"]),
    ("enrichment parameter of the model, not of the enrichment", lambda t: t + "\n[enrichment.anisotropy]\n"
     "omega = [1, 2]\n", ["enrichment.anisotropy.omega = [1, 2]: not a parameter of the 'anisotropy' enrichment",
                          "it adds alpha0, omega_ratio"]),
    ("enrichment of another family", lambda t: t + "\n[enrichment.state_dependent_dilatancy]\nn_p = [1, 2]\n",
     ["enrichment.state_dependent_dilatancy", "no enrichment of ModifiedCamClay for 'state-dependent dilatancy'"]),
    ("enrichment without its forward model", lambda t: t + "\n[enrichment.partial_drainage]\n"
     "permeability = [1e-10, 1e-7]\n", ["enrichment.partial_drainage", "this study has no pressuremeter test"]),
    ("enrichment given twice", lambda t: t + "\n[enrichment.time_dependent_swelling]\ntau_s = [1e3, 1e6]\n"
     '[enrichment."time-dependent swelling"]\nkappa_s = [0.001, 0.01]\n',
     ["enrichment.time-dependent swelling", "is given twice (as 'time-dependent swelling' and "
      "'time_dependent_swelling'): keep one"]),
]


SBP_TOMLS = [
    ("sbp strain rate 0", edit("strain_rate = 0.00167", "strain_rate = 0.0"), ["tests['SBP_fast'].strain_rate"]),
    ("sbp probe radius", edit("probe_radius = 0.0415", "probe_radius = 0"), ["tests['SBP_fast'].probe_radius"]),
    ("sbp quick outer radius", edit("[fe.quick]\nradial_cells = 20\nlayers = 1\nincrements = 20\nouter = \"field\"\n"
                                     "outer_radius_a0 = 200.0", "[fe.quick]\nouter_radius_a0 = 0.5"),
     ["fe.quick.outer_radius_a0", "0.5"]),
    ("sbp increments 0", edit("increments = 40", "increments = 0"), ["fe.increments", "0"]),
    ("sbp radial cells -1", edit("radial_cells = 20", "radial_cells = -1"), ["fe.quick.radial_cells", "-1"]),
    ("sbp permeability", edit("permeability = 3.3e-9", "permeability = -3.3e-9"), ["tests['SBP_fast'].permeability"]),
    ("sbp with MCC", edit('name = "ANICREEP"', 'name = "SIMSAND"'), ["SIMSAND"]),
]


CALIBRATE_ARGS = [
    ("seed -1", ["--seed", "-1"], ["--seed", "'-1'"]),
    ("seed text", ["--seed", "one"], ["--seed", "'one'"]),
    ("samples 2", ["--samples", "2"], ["--samples", "'2'"]),
    ("runs 0", ["--runs", "0"], ["--runs", "'0'"]),
    ("processes 0", ["--processes", "0"], ["--processes", "'0'"]),
    ("method", ["--method", "mh"], ["--method", "'mh'"]),
    ("dispatch", ["--dispatch", "fast"], ["--dispatch", "'fast'"]),
    ("noise negative", ["--generate", "--noise", "-0.1"], ["--noise", "'-0.1'"]),
    ("noise in %", ["--generate", "--noise", "2%"],
     ["--noise", "'2%'", "give the noise level", "as a plain number (2 % = 0.02: write 0.02)"]),
    ("noise nan", ["--generate", "--noise", "nan"], ["--noise", "'nan'"]),
    ("unknown option", ["--sampels", "8"], ["--sampels"]),
    ("generate without synthetic", ["--generate"], ["study.toml", "synthetic.parameters"]),
]


BURSWOOD_ARGS = [
    ("recordings without =", ["--recordings", "{f}"], ["--recordings", "NAME=VALUE"]),
    ("recordings without name", ["--recordings", "={f}"], ["--recordings", "NAME=VALUE"]),
    ("recordings twice", ["--recordings", "fast={f}", "fast={f}"], ["--recordings", "'fast' is given twice"]),
    ("recordings no rate", ["--recordings", "deep={f}"], ["--recordings", "deep", "--rates"]),
    ("recordings missing file", ["--recordings", "fast={d}/none.csv"], ["none.csv", "not found"]),
    ("recordings a folder", ["--recordings", "fast={d}"], ["not a file"]),
    ("rate 0", ["--recordings", "fast={f}", "--rates", "fast=0"], ["--rates", "fast=0", "> 0"]),
    ("rate negative", ["--recordings", "fast={f}", "--rates", "fast=-0.001"], ["--rates", "fast=-0.001"]),
    ("rate text", ["--recordings", "fast={f}", "--rates", "fast=quick"], ["--rates", "'quick'"]),
    ("rate nan", ["--recordings", "fast={f}", "--rates", "fast=nan"], ["--rates", "'nan'"]),
    ("rate inf", ["--recordings", "fast={f}", "--rates", "fast=inf"], ["--rates", "'inf'"]),
    ("rate in %", ["--recordings", "fast={f}", "--rates", "fast=0.167%"],
     ["--rates fast=0.167%: give the cavity strain rate as a number in 1/s (0.167 %/s = 0.00167 1/s: write 0.00167)"]),
    ("rate in %/min", ["--rates", "fast=1%/min"],
     ["--rates fast=1%/min: give the cavity strain rate as a number in 1/s (1 %/min = 0.000166667 1/s"]),
    ("rate in furlongs", ["--rates", "fast=2furlongs"],
     ["--rates fast=2furlongs: give the cavity strain rate as a number in 1/s (unit 'furlongs' not understood)"]),
    ("radial cells 0", ["--radial-cells", "0"], ["--radial-cells", "'0'"]),
    ("layers 0", ["--layers", "0"], ["--layers", "'0'"]),
    ("increments -5", ["--increments", "-5"], ["--increments", "'-5'"]),
    ("increments text", ["--increments", "many"], ["--increments", "'many'"]),
    ("increments float", ["--increments", "10.5"], ["--increments", "'10.5'"]),
    ("sweeps -1", ["--sweeps", "-1"], ["--sweeps", "'-1'"]),
    ("max stages 0", ["--max-stages", "0"], ["--max-stages", "'0'"]),
    ("timeout 0", ["--timeout", "0"], ["--timeout", "'0'"]),
    ("timeout -1", ["--timeout", "-1"], ["--timeout", "'-1'"]),
    ("timeout in min", ["--timeout", "10min"],
     ["--timeout", "'10min'", "give the time per forward evaluation as a number in s (10 min = 600 s: write 600)"]),
    ("throughput 0", ["--throughput", "0"], ["--throughput", "'0'"]),
    ("fixed nu 0.7", ["--fixed", "nu=0.7"], ["--fixed", "nu=0.7", "nu"]),
    ("fixed unknown", ["--fixed", "phi=30"], ["--fixed", "'phi'"]),
    ("fixed lambda", ["--fixed", "lambda_=0.01"], ["--fixed", "lambda_=0.01"]),
    ("fixed e0", ["--fixed", "e0=-1"], ["--fixed", "e0=-1"]),
    ("fixed inf", ["--fixed", "nu=inf"], ["--fixed", "'inf'"]),
    ("fixed text", ["--fixed", "nu=abc"], ["--fixed", "'abc'"]),
    ("fixed tau 0", ["--fixed", "tau=0"], ["--fixed", "tau=0"]),
    ("fixed tau in days", ["--fixed", "tau=1d"],
     ["--fixed tau=1d: give the fixed tau as a number in s (1 d = 86400 s: write 86400)"]),
    ("fixed nu in %", ["--fixed", "nu=30%"],
     ["--fixed nu=30%: give the fixed nu as a plain number (30 % = 0.3: write 0.3)"]),
    ("seed -1", ["--seed", "-1"], ["--seed", "'-1'"]),
    ("samples 2", ["--samples", "2"], ["--samples", "'2'"]),
    ("runs 0", ["--runs", "0"], ["--runs", "'0'"]),
    ("processes -2", ["--processes", "-2"], ["--processes", "'-2'"]),
    ("method", ["--method", "x"], ["--method", "'x'"]),
    ("unknown option", ["--recordigns", "fast={f}"], ["--recordigns"]),
    ("pore pressure in one record only", ["--recordings", "fast={f}", "slow={p}"],
     ["pressure_only.csv", "no pore_pressure_kPa column", "--pressure-only"]),
]


def variants(plain: str, renames: dict, scale: dict):
    """Encodings, line ends, quoting, unit spellings and a spreadsheet's saving of the same records: (name, bytes)."""
    header, *rows = [line for line in plain.splitlines() if not line.startswith("#")]
    quoted = "\n".join([header] + [",".join(f'"{v}"' for v in r.split(",")) for r in rows]) + "\n"
    bracket = plain.replace(header, ",".join(renames.get(c, c) for c in header.split(",")))
    names = header.split(",")
    scaled = ",".join(f"{n[: -len('_kPa')]} [MPa]" if n in scale else n for n in names)
    mpa = "\n".join([scaled] + [",".join(repr(float(v) / 1000) if n in scale else v
                                         for n, v in zip(names, r.split(","))) for r in rows]) + "\n"
    return [("CRLF", plain.replace("\n", "\r\n").encode()), ("BOM", b"\xef\xbb\xbf" + plain.encode()),
            ("BOM and CRLF", b"\xef\xbb\xbf" + plain.replace("\n", "\r\n").encode()), ("quoted", quoted.encode()),
            ("bracket units", bracket.encode()), ("MPa", mpa.encode()), ("spaces", plain.replace(",", ", ").encode()),
            ("old Mac CR", plain.replace("\n", "\r").encode()),
            ("spreadsheet", spreadsheet(plain).encode("utf-8-sig").replace(b"\n", b"\r\n")),
            ("semicolons, decimal points", plain.replace(",", ";").encode())]


def spreadsheet(plain: str) -> str:
    """The records as a spreadsheet in a comma-decimal locale saves them: ';' between the columns, decimal commas,
    headers ``name (unit)`` with blanks in the names (``axial strain (%)``)."""
    lines = []
    for line in plain.splitlines():
        if line.startswith("#"):
            lines.append(line)
        elif not lines or lines[-1].startswith("#"):
            names = [n.rsplit("_", 1) if n.rsplit("_", 1)[-1] in ("pct", "kPa", "s") else [n] for n in line.split(",")]
            lines.append(";".join(" ".join(n[0].split("_")) + (f" ({'%' if n[1] == 'pct' else n[1]})"
                                                                 if len(n) == 2 else "") for n in names))
        else:
            lines.append(line.replace(",", ";").replace(".", ","))
    return "\n".join(lines) + "\n"


LAB_VARIANTS = variants(LAB_CSV, {"axial_strain_pct": "axial_strain [%]", "q_kPa": "q [kPa]"}, {"q_kPa"})
SBP_VARIANTS = variants(SBP_CSV, {"cavity_strain_pct": "cavity_strain [%]", "time_s": "time [s]",
                                   "cavity_pressure_kPa": "cavity_pressure [kPa]"},
                         {"cavity_pressure_kPa", "pore_pressure_kPa"})
