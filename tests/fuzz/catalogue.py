"""A fixed catalogue of malformed inputs (issue 9) and of valid-but-unusual ones.

Each case breaks one thing in one valid file (:func:`tests.fuzz.corpus.valid_files`) and
names the command that reads it.  ``expect="refused"`` cases must end ``clear``;
``expect="accepted"`` ones must succeed (exit 0) quickly.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass

from tests.fuzz.corpus import MODEL, valid_files

Mutation = Callable[[dict[str, str]], dict[str, str | bytes]]

PREDICT = ["predict", "--machine", "{machine}", "--params", "{params}", "{records}", "-o", "{out}"]
CHECK = ["machine", "check", "{machine}"]
SHOW = ["machine", "show", "{machine}"]
IDENT = ["machine", "identifiability", "{machine}", "{poses}", "--artefact", "{artefact}"]
FIT = ["fit", "sphere", "{points}"]
UNC = ["uncertainty", "run", "{model}", "--method", "both", "--trials", "20000", "--seed", "1"]


@dataclass(frozen=True)
class Case:
    id: str
    mutate: Mutation
    args: tuple[str, ...]
    names: str | None  # placeholder of the file the error must name (None: an option)
    expect: str = "refused"


def _replace(key: str, old: str, new: str) -> Mutation:
    def mutate(files):
        assert old in files[key], (key, old)
        return {**files, key: files[key].replace(old, new, 1)}

    return mutate


def _set(key: str, content: str | bytes) -> Mutation:
    return lambda files: {**files, key: content}


def _json(key: str, change: Callable[[dict], None]) -> Mutation:
    def mutate(files):
        doc = json.loads(files[key])
        change(doc)
        return {**files, key: json.dumps(doc, indent=2)}

    return mutate


def _entry(field: str, value) -> Callable[[dict], None]:
    return lambda doc: doc["parameters"][2].update({field: value})


def _csv_cell(key: str, row: int, col: int, cell: str) -> Mutation:
    def mutate(files):
        lines = files[key].split("\n")
        cells = lines[row].split(",")
        cells[col] = cell
        lines[row] = ",".join(cells)
        return {**files, key: "\n".join(lines)}

    return mutate


def _csv_lines(key: str, change: Callable[[list[str]], list[str]]) -> Mutation:
    def mutate(files):
        return {**files, key: "\n".join(change(files[key].split("\n")))}

    return mutate


TOOL = "tool_mm: [0, 0, -150]"
X_AXIS = "X: {direction: +X, sign: -1, travel_mm: [-220, 230], resolution_mm: 0.0005}"
DEEP = "a: " + "[" * 200 + "1" + "]" * 200 + "\n"

MACHINE_CASES = [
    ("tool-nan", _replace("machine", TOOL, "tool_mm: [0, 0, .nan]")),
    ("tool-inf", _replace("machine", TOOL, "tool_mm: [0, .inf, -150]")),
    ("tool-string-number", _replace("machine", TOOL, 'tool_mm: [0, 0, "-150"]')),
    ("tool-bool", _replace("machine", TOOL, "tool_mm: [0, true, -150]")),
    ("tool-two-values", _replace("machine", TOOL, "tool_mm: [0, -150]")),
    ("offset-nan", _replace("machine", "offset_mm: [0, 0, 150]", "offset_mm: [0, .nan, 150]")),
    ("direction-nan", _replace("machine", "direction: +X,", "direction: [.nan, 0, 0],")),
    ("direction-zero", _replace("machine", "direction: +X,", "direction: [0, 0, 0],")),
    ("direction-word", _replace("machine", "direction: +X,", "direction: +W,")),
    ("travel-inf", _replace("machine", "travel_mm: [-220, 230]", "travel_mm: [-220, .inf]")),
    ("travel-reversed", _replace("machine", "travel_mm: [-220, 230]", "travel_mm: [230, -220]")),
    ("travel-string", _replace("machine", "travel_mm: [-220, 230]", 'travel_mm: ["-220", 230]')),
    ("travel-deg-on-linear", _replace("machine", "travel_mm: [-220, 230]", "travel_deg: [-1, 1]")),
    (
        "sign-true",
        _replace("machine", "sign: -1, travel_mm: [-220", "sign: true, travel_mm: [-220"),
    ),
    ("sign-two", _replace("machine", "sign: -1, travel_mm: [-220", "sign: 2, travel_mm: [-220")),
    ("version-99", _replace("machine", "version: 1", "version: 99")),
    ("version-true", _replace("machine", "version: 1", "version: true")),
    ("kind-wrong", _replace("machine", "kind: machine", "kind: parameter-set")),
    ("duplicate-tool", _replace("machine", TOOL, TOOL + "\ntool_mm: [0, 0, -450]")),
    ("duplicate-axis", _replace("machine", X_AXIS, X_AXIS + "\n  " + X_AXIS)),
    ("unknown-key", _replace("machine", TOOL, TOOL + "\ntools_mm: [0, 0, 1]")),
    ("unknown-axis-key", _replace("machine", "resolution_mm: 0.0005}", "resolution: 0.0005}")),
    ("resolution-negative", _replace("machine", "resolution_mm: 0.0005}", "resolution_mm: -1}")),
    ("tip-negative", _replace("machine", "tip_radius_mm: 2.9625", "tip_radius_mm: -2")),
    ("topology-garbage", _replace("machine", "topology: WCBXFZYST", "topology: WQQ")),
    ("name-number", _replace("machine", "name: five-axis-wcbxfzyst", "name: 5")),
    ("param-degree-huge", _replace("machine", "E_XX1, E_YY1", "E_XX100000, E_YY1")),
    ("param-not-iso", _replace("machine", "E_XX1, E_YY1", "E_QQ1, E_YY1")),
    ("default-model-missing", _replace("machine", 'default_model: "13"', 'default_model: "99"')),
    ("alias", _replace("machine", TOOL, "tool_mm: &t [0, 0, -150]\nworkpiece_offset_mm: *t")),
    ("deep-nesting", lambda f: {**f, "machine": f["machine"] + DEEP}),
    ("tab-indent", _replace("machine", "  X: {", "\tX: {")),
    ("not-a-mapping", _set("machine", "- just\n- a list\n")),
    ("empty", _set("machine", "")),
    ("binary", _set("machine", b"\x00\xff\xfe" * 100)),
    ("python-tag", _replace("machine", TOOL, "tool_mm: !!python/tuple [0, 0, -150]")),
]

PARAMS_CASES = [
    ("kind-wrong", _json("params", lambda d: d.update(kind="machine"))),
    ("kind-missing", _json("params", lambda d: d.pop("kind"))),
    ("version-99", _json("params", lambda d: d.update(version=99))),
    ("version-true", _json("params", lambda d: d.update(version=True))),
    ("machine-other", _json("params", lambda d: d.update(machine="cmm-moving-bridge"))),
    ("machine-missing", _json("params", lambda d: d.pop("machine"))),
    ("model-unknown", _json("params", lambda d: d.update(model="99"))),
    ("unknown-key", _json("params", lambda d: d.update(paramters=[]))),
    ("value-true", _json("params", _entry("value", True))),
    ("value-string", _json("params", _entry("value", "12.5"))),
    ("value-null", _json("params", _entry("value", None))),
    ("value-list", _json("params", _entry("value", [1]))),
    ("value-huge", _json("params", _entry("value", 1e308))),
    ("unit-wrong-dimension", _json("params", _entry("unit", "µrad"))),
    ("unit-unknown", _json("params", _entry("unit", "furlong"))),
    ("u-negative", _json("params", _entry("u", -1.0))),
    ("name-not-iso", _json("params", _entry("name", "E_QQ1"))),
    ("name-degree-huge", _json("params", _entry("name", "E_XX99999"))),
    ("entry-unknown-key", _json("params", _entry("sigma", 1.0))),
    ("parameters-empty", _json("params", lambda d: d.update(parameters=[]))),
    ("parameters-twice", _json("params", lambda d: d["parameters"].append(d["parameters"][0]))),
    ("nan-literal", _replace("params", '"value": ', '"value": NaN, "x": ')),
    ("duplicate-key", _replace("params", '"version": 1,', '"version": 1,\n  "version": 1,')),
    ("not-json", _set("params", "{ this is not json")),
    (
        "covariance-asymmetric",
        _json(
            "params",
            lambda d: d.update(
                covariance={
                    "names": [p["name"] for p in d["parameters"]],
                    "matrix": [
                        [
                            1.0 if i == j else (0.5 if i < j else 0.0)
                            for j in range(len(d["parameters"]))
                        ]
                        for i in range(len(d["parameters"]))
                    ],
                }
            ),
        ),
    ),
]

_RECORD_ROW = 5  # data row 5 is file line 6
RECORDS_CASES = [
    (
        "duplicate-header",
        _csv_lines(
            "records",
            lambda ls: ["X,Y,Z,B,C,X", *[line + ",0" if line else line for line in ls[1:]]],
        ),
    ),
    ("underscore-digits", _csv_cell("records", _RECORD_ROW, 0, "1_000")),
    ("arabic-indic-digits", _csv_cell("records", _RECORD_ROW, 1, "\u0661\u0662")),
    ("full-width-digits", _csv_cell("records", _RECORD_ROW, 2, "\uff11\uff12")),
    ("hexadecimal", _csv_cell("records", _RECORD_ROW, 0, "0x10")),
    ("outside-travel", _csv_cell("records", _RECORD_ROW, 0, "1e6")),
    ("outside-travel-rotary", _csv_cell("records", _RECORD_ROW, 3, "135")),
    ("huge", _csv_cell("records", _RECORD_ROW, 4, "1e308")),
    ("overflow", _csv_cell("records", _RECORD_ROW, 4, "1e400")),
    ("nan", _csv_cell("records", _RECORD_ROW, 0, "nan")),
    ("inf", _csv_cell("records", _RECORD_ROW, 1, "-inf")),
    ("empty-cell", _csv_cell("records", _RECORD_ROW, 2, "")),
    ("word", _csv_cell("records", _RECORD_ROW, 2, "twelve")),
    ("extra-field", _csv_cell("records", _RECORD_ROW, 4, "1,2")),
    ("missing-field", _csv_lines("records", lambda ls: [*ls[:6], "1,2,3", *ls[7:]])),
    (
        "missing-column",
        _csv_lines("records", lambda ls: [",".join(line.split(",")[:4]) for line in ls]),
    ),
    ("header-only", _set("records", "X,Y,Z,B,C\n")),
    ("empty", _set("records", "")),
    ("comments-only", _set("records", "# nothing\n\n")),
    ("not-utf8", lambda f: {**f, "records": f["records"].encode().replace(b"\n", b"\n\xff", 1)}),
    ("quoted-newline", _csv_cell("records", _RECORD_ROW, 4, '"1\n2"')),
    (
        "sense-half",
        _csv_lines(
            "records",
            lambda ls: [
                (line + (",sense_B" if i == 0 else ",0.5")) if line else line
                for i, line in enumerate(ls)
            ],
        ),
    ),
]

POINTS_CASES = [
    ("duplicate-header", _set("points", "x,y,z,z\n1,2,3,4\n")),
    ("underscore-digits", _csv_cell("points", 3, 0, "1_0")),
    ("huge", _csv_cell("points", 3, 1, "1e308")),
    ("nan", _csv_cell("points", 3, 2, "NaN")),
    ("too-few", _csv_lines("points", lambda ls: ls[:3])),
    ("missing-z", _set("points", "x,y\n1,2\n3,4\n5,6\n7,8\n")),
]

POSES_CASES = [
    (
        "missing-ball",
        _csv_lines("poses", lambda ls: [",".join(line.split(",")[1:]) for line in ls]),
    ),
    ("outside-travel", _csv_cell("poses", 4, 3, "-500")),
    ("underscore-digits", _csv_cell("poses", 4, 1, "1_0")),
]

ARTEFACT_CASES = [
    ("length-nan", _replace("artefact", "length_mm: 305.2105", "length_mm: .nan")),
    ("u-true", _replace("artefact", "u_mm: 0.0012", "u_mm: true")),
    ("u-string", _replace("artefact", "u_mm: 0.0012", 'u_mm: "0.0012"')),
    ("version-99", _replace("artefact", "version: 1", "version: 99")),
    ("unknown-key", _replace("artefact", "version: 1", "version: 1\nstylus: 3")),
    ("duplicate-key", _replace("artefact", "version: 1", "version: 1\nversion: 1")),
    ("end-not-a-ball", _replace("artefact", "ends: [SB1, SB2]", "ends: [SB1, SB9]")),
]


def _chain(n: int) -> str:
    outs = ['  - {name: y0, expression: "a + b", unit: µm}'] + [
        f'  - {{name: y{k}, expression: "(y{k - 1} + y{k - 1}) / 2", unit: µm}}'
        for k in range(1, n)
    ]
    return MODEL.split("outputs:")[0] + "outputs:\n" + "\n".join(outs) + "\n"


MODEL_CASES = [
    (
        "unit-rad-for-length",
        _replace("model", 'expression: "a + b", unit: µm', 'expression: "a + b", unit: rad'),
    ),
    (
        "sum-of-length-and-temperature",
        _replace("model", "unit: µm}\n  - {name: b", "unit: °C}\n  - {name: b"),
    ),
    ("duplicate-key", _replace("model", "name: sum and difference", "name: x\nname: y")),
    ("u-true", _replace("model", "u: 0.3", "u: true")),
    ("value-string", _replace("model", "value: 10.0", 'value: "10.0"')),
    ("value-nan", _replace("model", "value: 10.0", "value: .nan")),
    ("version-99", _replace("model", "version: 1", "version: 99")),
    ("unknown-key", _replace("model", "version: 1", "version: 1\noutput: []")),
    ("dof-true", _replace("model", "u: 0.3,", "u: 0.3, dof: true,")),
    (
        "correlation-two",
        lambda f: {**f, "model": f["model"] + "correlations:\n  - {inputs: [a, b], r: 2}\n"},
    ),
    (
        "distribution-string",
        _replace(
            "model", "value: 5.0, u: 0.4", 'distribution: {kind: rectangular, x: 5, a: "0.4"}'
        ),
    ),
    ("import", _replace("model", '"a + b"', "\"__import__('os').getcwd()\"")),
    ("attribute", _replace("model", '"a + b"', '"a.real + b"')),
    ("huge-expression", _replace("model", '"a + b"', '"' + "+".join(["a"] * 50_000) + '"')),
    ("deep-parentheses", _replace("model", '"a + b"', '"' + "(" * 300 + "a" + ")" * 300 + '"')),
    ("deep-unary-chain", _replace("model", '"a + b"', '"' + "-" * 3000 + "a" + '"')),
    ("deep-sum", _replace("model", '"a + b"', '"' + "+".join(["a"] * 3000) + '"')),
    ("deep-yaml", lambda f: {**f, "model": f["model"] + DEEP}),
    ("constant-overflow", _replace("model", '"a + b"', '"a + 10**400"')),
]

OPTION_CASES = [
    ("trials-huge", [*UNC[:3], "--method", "mcm", "--trials", "10000000000000"], None),
    ("trials-one", [*UNC[:3], "--method", "mcm", "--trials", "1"], None),
    (
        "adaptive-digits-12",
        ["uncertainty", "run", "{model}", "--method", "mcm", "--adaptive", "--digits", "12"],
        None,
    ),
    ("p-above-one", ["uncertainty", "run", "{model}", "--p", "1.5"], None),
    (
        "show-degree-huge",
        ["machine", "show", "{machine}", "--catalogue", "--degree", "100000"],
        None,
    ),
    (
        "show-degree-negative",
        ["machine", "show", "{machine}", "--catalogue", "--degree", "-1"],
        None,
    ),
    ("sigma-nan", [*IDENT, "--sigma-um", "nan"], None),
    ("tip-radius-negative", [*FIT, "--tip-radius", "-1"], None),
    ("output-onto-input", [*PREDICT[:-1], "{records}"], "records"),
    ("output-missing-directory", [*PREDICT[:-1], "{dir}/missing/out.csv"], "out.csv"),
    ("output-is-directory", [*PREDICT[:-1], "{dir}"], "dir"),
    ("records-is-directory", ["predict", "--machine", "{machine}", "{dir}"], "dir"),
    ("records-missing", ["predict", "--machine", "{machine}", "{dir}/none.csv"], "none.csv"),
]


def _unusual_records(files):
    lines = files["records"].strip("\n").split("\n")
    header = "  " + ",  ".join(lines[0].split(",")) + " , note"
    rows = [f" {line} ,row {i}" for i, line in enumerate(lines[1:])]
    text = "\ufeff# exported 2026-11-24\r\n" + header + "\r\n" + "\r\n\r\n".join(rows) + "\r\n"
    return {**files, "records": text}


ACCEPTED_CASES = [
    ("records-bom-crlf-comments-padding-extra-column", _unusual_records, PREDICT, None),
    ("machine-comments", lambda f: {**f, "machine": "# a comment\n" + f["machine"]}, CHECK, None),
    ("model-chain-40-outputs", lambda f: {**f, "model": _chain(40)}, UNC, None),
    ("params-yaml-equivalent", lambda f: f, PREDICT, None),
]


def cases() -> list[Case]:
    """Every case of the catalogue."""
    out: list[Case] = []
    for name, mutate in MACHINE_CASES:
        for label, args in (("check", CHECK), ("predict", PREDICT)):
            out.append(Case(f"machine-{name}-{label}", mutate, tuple(args), "machine"))
    for name, mutate in PARAMS_CASES:
        out.append(Case(f"params-{name}", mutate, tuple(PREDICT), "params"))
    for name, mutate in RECORDS_CASES:
        out.append(Case(f"records-{name}", mutate, tuple(PREDICT), "records"))
    for name, mutate in POINTS_CASES:
        out.append(Case(f"points-{name}", mutate, tuple(FIT), "points"))
    for name, mutate in POSES_CASES:
        out.append(Case(f"poses-{name}", mutate, tuple(IDENT), "poses"))
    for name, mutate in ARTEFACT_CASES:
        out.append(Case(f"artefact-{name}", mutate, tuple(IDENT), "artefact"))
    for name, mutate in MODEL_CASES:
        out.append(Case(f"model-{name}", mutate, tuple(UNC), "model"))
    for name, args, names in OPTION_CASES:
        out.append(Case(f"option-{name}", lambda f: f, tuple(args), names))
    for name, mutate, args, names in ACCEPTED_CASES:
        out.append(Case(f"accepted-{name}", mutate, tuple(args), names, expect="accepted"))
    return out


def base_files() -> dict[str, str]:
    """The valid files, computed once per process."""
    global _BASE
    if _BASE is None:
        _BASE = valid_files()
    return _BASE


_BASE: dict[str, str] | None = None
